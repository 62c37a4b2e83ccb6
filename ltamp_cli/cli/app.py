"""The ``ltamp`` Typer application.

Each command lives in its own module with a ``register(app)`` function. Errors caused by bad
input are :class:`~ltamp_cli.errors.InputError`: :func:`main` prints them as one line on
stderr and exits with code 2. Conventions shared by every command (see the README):
``--version``, shell completion (``--install-completion``), ``-v``/``-q`` for the log level
(logging goes to stderr), ``--json`` on every command, progress on stderr only on a TTY,
and Ctrl-C ends with one line and exit code 130.
"""

from __future__ import annotations

import sys
from typing import Annotated

import typer

from ltamp_cli.cli.conventions import CliSettings, configure_logging
from ltamp_cli.errors import InputError

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


def _version_option(value: bool) -> None:
    if value:
        from importlib.metadata import PackageNotFoundError, version

        try:
            typer.echo(f"ltamp {version('ltamp')}")
        except PackageNotFoundError:  # a bare checkout on PYTHONPATH, never installed
            typer.echo("ltamp (not installed: version unknown)")
        raise typer.Exit(0)


def root_options(
    verbose: Annotated[int, typer.Option(
        "-v", "--verbose", count=True, help="More log messages on stderr (-vv: debug).")] = 0,
    quiet: Annotated[bool, typer.Option(
        "-q", "--quiet", help="Only errors on stderr: no progress, no warnings.")] = False,
    version: Annotated[bool, typer.Option(
        "--version", is_eager=True, callback=_version_option,
        help="Print the version and exit.")] = False,
) -> None:
    """Learn skills from few trials and plan with them."""
    if verbose and quiet:
        raise InputError("-v/--verbose and -q/--quiet exclude each other")
    settings = CliSettings(verbosity=-1 if quiet else verbose)
    configure_logging(settings)


def build_app() -> typer.Typer:
    app = typer.Typer(
        name="ltamp",
        no_args_is_help=True,
        add_completion=True,
        pretty_exceptions_enable=False,
    )
    app.callback()(root_options)
    # Command modules are imported here, not at module import, to keep start-up cheap.
    from ltamp_cli.cli import (
        check,
        collect,
        evaluate,
        import_trials,
        pddlstream,
        plot,
        problems,
        sample,
        skills,
        solve,
        tell,
        train,
    )

    for module in (solve, problems, check, collect, skills, train, evaluate, sample,
                   import_trials, tell, plot, pddlstream):
        module.register(app)
    return app


def main(argv: list[str] | None = None) -> None:
    """Console entry point: run the app, turning input errors into exit code 2."""
    try:
        app = build_app()
        code = app(args=argv, prog_name="ltamp", standalone_mode=False)
    except InputError as error:
        print(f"ltamp: error: {error}", file=sys.stderr)
        sys.exit(EXIT_BAD_INPUT)
    except typer.Exit as done:
        sys.exit(done.exit_code)
    except (typer.Abort, KeyboardInterrupt):
        print("ltamp: interrupted", file=sys.stderr)
        sys.exit(EXIT_INTERRUPTED)
    except typer.TyperException as error:  # usage errors: bad options or arguments
        format_message = getattr(error, "format_message", None)
        message = " ".join(str(format_message() if callable(format_message) else error).split())
        if not message:  # `ltamp` or `ltamp plot` alone: the help was printed, nothing wrong
            sys.exit(0)
        print(f"ltamp: error: {message}", file=sys.stderr)
        sys.exit(EXIT_BAD_INPUT)
    if code == EXIT_INTERRUPTED:  # Typer turns Ctrl-C (KeyboardInterrupt) into 130, silently
        print("ltamp: interrupted", file=sys.stderr)
    sys.exit(code if isinstance(code, int) else 0)
