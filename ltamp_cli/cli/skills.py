"""``ltamp skills``: list every backend's skills with their parameter names and bounds."""

from __future__ import annotations

import json
from typing import Annotated, Any

import typer


def register(app: typer.Typer) -> None:
    app.command(name="skills")(skills_command)


def _space(space: Any) -> list[dict[str, Any]]:
    return [
        {"name": name, "low": low, "high": high}
        for name, low, high in zip(space.names, space.lows, space.highs, strict=True)
    ]


def backend_listing(name: str) -> dict[str, Any]:
    """``{"name", "available", "skills" | "error"}`` for one backend (never raises)."""
    from ltamp_cli.backends import load_backend

    try:
        backend = load_backend(name)
    except Exception as error:  # an unimplemented or broken backend is reported, not fatal
        return {"name": name, "available": False, "error": " ".join(str(error).split())}
    try:
        skills = [
            {
                "name": spec.name,
                "description": spec.description,
                "invalid_score": spec.invalid_score,
                "control": _space(spec.control),
                "context": _space(spec.context),
            }
            for spec in backend.skills().values()
        ]
    finally:
        backend.close()
    return {"name": name, "available": True, "skills": skills}


def skills_command(
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of text.")] = False,
) -> None:
    """List every backend's skills: context and control parameters with their bounds.

    Backends of installed plugins (entry points of group `ltamp.backends`) are listed too.
    """
    from ltamp_cli.backends import discover_backends

    listings = [backend_listing(name) for name in discover_backends()]
    if as_json:
        typer.echo(json.dumps({"backends": listings}, indent=2))
        return
    for listing in listings:
        if not listing["available"]:
            typer.echo(f"{listing['name']}: unavailable ({listing['error']})")
            continue
        typer.echo(f"{listing['name']}:")
        for skill in listing["skills"]:
            typer.echo(f"  {skill['name']}: {skill['description']}")
            for role in ("control", "context"):
                for p in skill[role]:
                    typer.echo(f"    {role:<7} {p['name']:<16} [{p['low']:g}, {p['high']:g}]")
