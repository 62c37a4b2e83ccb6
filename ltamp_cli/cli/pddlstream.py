"""``ltamp pddlstream run``: run a PDDLStream script unmodified (its ``pddlstream.*``
imports served by ``ltamp_cli.pddlstream``; see :mod:`ltamp_cli.pddlstream.run`)."""

from __future__ import annotations

from typing import Annotated, Any

import typer

RUN_HELP = (
    "Run SCRIPT as __main__ with its `pddlstream.*` imports served by ltamp_cli.pddlstream."
    "\n\n"
    "Options go before SCRIPT; everything after it is the script's own command line. Exit "
    "code: the script's; 2 with one line if it needs a PDDLStream name ltamp lacks or ltamp "
    "rejects its problem; 1 with its traceback if it fails in its own code. NumPy-1 names "
    "that NumPy 2 removed and that have an exact NumPy 2 equivalent (np.mat, np.product, "
    "np.float_, np.NaN, ...) are added back for the script unless --no-numpy-compat."
)


def register(app: typer.Typer) -> None:
    pddlstream_app = typer.Typer(help="Run PDDLStream scripts with ltamp's planner.",
                                 no_args_is_help=True)
    pddlstream_app.command(
        name="run",
        help=RUN_HELP,
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
    no_numpy_compat: Annotated[bool, typer.Option(
        "--no-numpy-compat", help="Do not add back the NumPy-1 names NumPy 2 removed "
        "(np.mat, np.product, np.float_, np.NaN, ...: those with an exact NumPy 2 "
        "equivalent, see docs/porting-from-pddlstream.md).")] = False,
    as_json: Annotated[bool, typer.Option(
        "--json", help="After the script's own output, print one JSON object: script, "
        "exit_code, cpu_s, error (the runner's one-line reason, if any).")] = False,
) -> None:
    """See :data:`RUN_HELP`."""
    import io
    import sys
    import time

    from ltamp_cli.cli.conventions import emit
    from ltamp_cli.pddlstream.run import run_target

    errors = _Tee(sys.stderr, io.StringIO())
    start = time.process_time()
    code = run_target(script, list(ctx.args), module=module, force=force, strict=strict,
                      numpy_compat=not no_numpy_compat, stderr=errors)
    if as_json:
        lines = errors.copy.getvalue().splitlines()
        error = next((line.removeprefix("ltamp: error: ") for line in reversed(lines)
                      if line.startswith("ltamp: ")), None)
        emit({"script": script, "module": module, "exit_code": code,
              "cpu_s": round(time.process_time() - start, 3), "error": error}, True)
    raise typer.Exit(code)


class _Tee:
    """Writes to ``target`` and keeps a copy (the runner's messages for ``--json``)."""

    def __init__(self, target: Any, copy: Any) -> None:
        self.target = target
        self.copy = copy

    def write(self, text: str) -> int:
        self.copy.write(text)
        return int(self.target.write(text))

    def flush(self) -> None:
        self.target.flush()
