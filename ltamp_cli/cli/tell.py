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
) -> None:
    """Record the pending trial's score in DIR/trials.jsonl, refit and save the model."""
    from ltamp_cli.cli.conventions import emit
    from ltamp_cli.learning.ask_tell import tell
    from ltamp_cli.threads import use_one_thread

    use_one_thread()
    record = tell(directory, score, valid, wait=wait)
    emit({"model": str(directory), "index": record.index, "score": score}, as_json)
