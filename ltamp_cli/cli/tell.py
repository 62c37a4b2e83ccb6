"""``ltamp tell``: record the outcome of the trial proposed by ``ltamp train --ask``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer


def register(app: typer.Typer) -> None:
    app.command(name="tell")(tell_command)


def tell_command(
    directory: Annotated[Path, typer.Argument(help="Model directory given to `train --ask`.")],
    score: Annotated[float, typer.Option("--score", help="Measured score (> 0 = success).")],
    valid: Annotated[
        bool, typer.Option("--valid/--invalid", help="Whether the trial could be run.")
    ] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
    wait: Annotated[
        bool, typer.Option("--wait", help="Wait for another writer of DIR instead of failing.")
    ] = False,
    outcome: Annotated[
        str | None,
        typer.Option("--outcome", help="What the trial observed, for a skill that declares an "
                     "outcome (e.g. the push's end position): comma-separated values in the "
                     "outcome's units, e.g. '1.5,-0.2'. The model then learns from it as "
                     "`ltamp train` does (hindsight relabelling)."),
    ] = None,
) -> None:
    """Record the pending trial's score in DIR/trials.jsonl, refit and save the model."""
    from ltamp_cli.cli.conventions import emit
    from ltamp_cli.errors import InputError
    from ltamp_cli.learning.ask_tell import tell
    from ltamp_cli.threads import use_one_thread

    use_one_thread()
    values = None
    if outcome is not None:
        try:
            values = [float(v) for v in outcome.split(",")]
        except ValueError:
            raise InputError(f"--outcome: expected comma-separated numbers, got "
                             f"{outcome!r:.60}") from None
    record = tell(directory, score, valid, wait=wait, outcome=values)
    summary = {"model": str(directory), "index": record.index, "score": score}
    if record.outcome is not None:
        summary["outcome"] = list(record.outcome)
    emit(summary, as_json)
