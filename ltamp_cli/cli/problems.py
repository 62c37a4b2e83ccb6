"""``ltamp problems``: list the built-in problems (usable by name in ``solve`` and ``check``)."""

from __future__ import annotations

import json
from typing import Annotated

import typer


def register(app: typer.Typer) -> None:
    app.command(name="problems")(problems_command)


def problems_command(
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of text.")] = False,
) -> None:
    """List the shipped problems: `ltamp solve NAME` solves one from any directory."""
    from ltamp_cli.shipped import builtin_problems

    listed = builtin_problems()
    if as_json:
        typer.echo(json.dumps({"problems": [
            {"name": p.name, "path": str(p.path), "summary": p.summary} for p in listed.values()
        ]}, indent=2))
        return
    width = max((len(name) for name in listed), default=0)
    for problem in listed.values():
        typer.echo(f"{problem.name:<{width}}  {problem.summary}")
