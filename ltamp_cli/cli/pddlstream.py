"""``ltamp pddlstream run``: run a PDDLStream script unmodified (its ``pddlstream.*``
imports served by ``ltamp_cli.pddlstream``; see :mod:`ltamp_cli.pddlstream.run`)."""

from __future__ import annotations

from typing import Annotated

import typer


def register(app: typer.Typer) -> None:
    pddlstream_app = typer.Typer(help="Run PDDLStream scripts with ltamp's planner.",
                                 no_args_is_help=True)
    pddlstream_app.command(
        name="run",
        context_settings={"allow_extra_args": True, "ignore_unknown_options": True,
                          "allow_interspersed_args": False},
    )(run_command)
    app.add_typer(pddlstream_app, name="pddlstream")


def run_command(
    ctx: typer.Context,
    script: Annotated[str, typer.Argument(
        help="The script (SCRIPT.py), or with -m a module name; what follows goes to it.",
        metavar="SCRIPT")],
    module: Annotated[bool, typer.Option(
        "-m", "--module", help="SCRIPT is a module name, run as `python -m` runs it (the "
        "current folder first on sys.path).")] = False,
    force: Annotated[bool, typer.Option(
        "--force", help="Shadow a real PDDLStream that is importable.")] = False,
    strict: Annotated[bool, typer.Option(
        "--strict", help="PDDLStream names ltamp lacks fail at import, not at use.")] = False,
) -> None:
    """Run SCRIPT as __main__ with `pddlstream.*` imports served by ltamp_cli.pddlstream.

    Options go before SCRIPT; everything after it is the script's own command line. Exit
    code: the script's; 2 with one line if it needs a PDDLStream name ltamp lacks or ltamp
    rejects its problem; 1 with its traceback if it fails in its own code.
    """
    from ltamp_cli.pddlstream.run import run_target

    raise typer.Exit(run_target(script, list(ctx.args), module=module, force=force,
                                strict=strict))
