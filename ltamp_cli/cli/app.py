"""The ``ltamp`` Typer application.

Each command lives in its own module with a ``register(app)`` function. Errors caused by bad
input are :class:`~ltamp_cli.errors.InputError`: :func:`main` prints them as one line on
stderr and exits with code 2.
"""

from __future__ import annotations

import sys

import typer

from ltamp_cli.errors import InputError

EXIT_BAD_INPUT = 2


def build_app() -> typer.Typer:
    app = typer.Typer(
        name="ltamp",
        help="Learn skills from few trials and plan with them.",
        no_args_is_help=True,
        add_completion=False,
        pretty_exceptions_enable=False,
    )
    # A callback keeps `ltamp COMMAND` form even while only one command is registered.
    app.callback()(lambda: None)
    # Command modules are imported here, not at module import, to keep start-up cheap.
    from ltamp_cli.cli import (
        check,
        collect,
        evaluate,
        import_trials,
        plot,
        sample,
        skills,
        solve,
        tell,
        train,
    )

    for module in (solve, collect, skills, train, evaluate, sample, check, import_trials, tell,
                   plot):
        module.register(app)
    return app


def main(argv: list[str] | None = None) -> None:
    """Console entry point: run the app, turning input errors into exit code 2."""
    app = build_app()
    try:
        code = app(args=argv, standalone_mode=False)
    except InputError as error:
        print(f"ltamp: error: {error}", file=sys.stderr)
        sys.exit(EXIT_BAD_INPUT)
    except typer.Exit as done:
        sys.exit(done.exit_code)
    except typer.Abort:
        print("ltamp: aborted", file=sys.stderr)
        sys.exit(130)
    except KeyboardInterrupt:
        print("ltamp: interrupted", file=sys.stderr)
        sys.exit(130)
    except typer.TyperException as error:  # usage errors: bad options or arguments
        format_message = getattr(error, "format_message", None)
        message = format_message() if callable(format_message) else str(error)
        print(f"ltamp: error: {' '.join(str(message).split())}", file=sys.stderr)
        sys.exit(EXIT_BAD_INPUT)
    sys.exit(code if isinstance(code, int) else 0)
