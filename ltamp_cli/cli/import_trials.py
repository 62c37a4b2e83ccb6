"""``ltamp import``: validate recorded trials (CSV/JSONL) and append them to a trial file."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ltamp_cli.cli.paths import writable_output_file
from ltamp_cli.errors import InputError


def register(app: typer.Typer) -> None:
    app.command(name="import")(import_command)


def import_command(
    source: Annotated[Path, typer.Argument(help="Recorded trials: FILE.csv or FILE.jsonl.")],
    skill: Annotated[str, typer.Option("--skill", help="Skill the trials belong to.")],
    out: Annotated[Path, typer.Option("--out", help="Trial JSONL to append to (created).")],
    backend: Annotated[
        str, typer.Option("--backend", help="Backend whose skill defines the parameters.")
    ] = "synthetic",
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
) -> None:
    """Convert recorded trials of SKILL into the trial format, skipping ones already in --out.

    Columns: every context and control parameter (see `ltamp skills`), `score`, optional
    `valid` and `seed`. Instead of `score`, pour and scoop trials may give the measured
    `fraction` (particles in the target, spoon filled) and get the skill's score for it (the
    box2d, pybullet and sapien backends; a plugin backend by defining
    `score_from_fraction(skill, fraction)`).
    """
    from ltamp_cli.backends import load_backend
    from ltamp_cli.cli.conventions import emit
    from ltamp_cli.trials.importing import import_file

    if out.exists() and not out.is_file():
        raise InputError(f"--out: {out} exists and is not a file")
    writable_output_file(out, "--out")
    physics = load_backend(backend)
    try:
        specs = physics.skills()
        if skill not in specs:
            raise InputError(
                f"--skill: backend {backend!r} has no skill {skill!r} "
                f"(known: {', '.join(sorted(specs))})"
            )
        score_from_fraction = getattr(physics, "score_from_fraction", None)
        summary = import_file(source, specs[skill], out, score_from_fraction)
    finally:
        physics.close()
    emit({"out": str(out), "rows": summary.rows, "added": summary.added,
          "skipped_duplicates": summary.skipped}, as_json)
