"""``ltamp collect``: run random trials of a skill into an append-only JSONL file."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from ltamp_cli.errors import InputError

if TYPE_CHECKING:
    from ltamp_cli.trials.collect import CollectJob

# The robot limits live with the collection API (`ltamp train` imports them from here).
from ltamp_cli.trials.robots import (
    ROBOT_BACKEND,
    ROBOT_CHOICES,
    ROBOT_SKILLS,
    check_robot,
)

__all__ = ["ROBOT_BACKEND", "ROBOT_CHOICES", "ROBOT_SKILLS", "check_robot", "register"]


def register(app: typer.Typer) -> None:
    app.command(name="collect")(collect_command)


def collect_command(
    skill: Annotated[str, typer.Argument(help="Skill to run, e.g. pour, scoop, push.")],
    n: Annotated[int, typer.Option("-n", help="Total number of trials wanted in the file.")],
    out: Annotated[Path, typer.Option("--out", help="JSONL file to append to (resumes).")],
    backend: Annotated[str, typer.Option("--backend", help="Physics backend.")] = "box2d",
    workers: Annotated[
        int | None,
        typer.Option(
            "--workers",
            help="Worker processes (default 1); with --ray, Ray actors (default: all CPUs).",
        ),
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help="Base seed; trial i uses (seed, i).")] = 0,
    valid_only: Annotated[
        bool, typer.Option("--valid-only", help="Redraw controls until one is valid.")
    ] = False,
    ray: Annotated[
        str | None,
        typer.Option(
            "--ray",
            help="Run trials on Ray: 'local' (a local cluster) or a cluster address. "
            "Needs the ltamp\\[ray] extra.",
        ),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
    wait: Annotated[
        bool, typer.Option("--wait", help="Wait for another writer of --out instead of failing.")
    ] = False,
    robot: Annotated[
        str,
        typer.Option(
            "--robot",
            help="Who moves the tool in a trial: 'none' (free-floating along the skill's path) "
            "or 'panda' (pybullet pour, scoop, push, stir: a Panda grasps the cup, spoon, "
            "fingertip pad or stirrer with a force-limited grasp and follows the path by IK "
            "and joint position control at the skill's speeds; unreachable poses, arm "
            "collisions and slip fail the trial; opt-in, see models/README.md for its "
            "label agreement and cost). Records are tagged pybullet+panda with the "
            "skill's robot setup version (\"setup\": \"panda-r3\"), so neither free and "
            "robot trials nor two setups mix in one file.",
        ),
    ] = "none",
) -> None:
    """Collect N random trials (uniform control; context from the backend), resumably."""
    from ltamp_cli.cli.conventions import emit, progress_enabled
    from ltamp_cli.trials.collect import CollectJob, collect

    # collect() checks -n, --workers, --out and --robot (the API's limits are the CLI's).
    job = CollectJob(skill=skill, backend=backend, n=n, seed=seed, valid_only=valid_only,
                     robot=robot)
    added = collect(job, out, workers=workers, ray_address=ray, wait=wait,
                    progress=progress_enabled())
    missing = _still_missing(job, out)
    if missing:
        # Another process truncated, rotated or replaced the file while this one appended:
        # "now holds trials 0..n-1" would be false.
        typer.echo(f"ltamp: warning: {out} lacks {missing} of trials 0..{n - 1} after this "
                   "run (was it truncated or replaced meanwhile?); run the same command "
                   "again to fill them in", err=True)
    if as_json:
        emit({"out": str(out), "added": added, "n": n, "missing": missing}, as_json)
    elif not missing:
        typer.echo(f"{added} new trials; {out} now holds trials 0..{n - 1}", err=True)
    else:
        typer.echo(f"{added} new trials; {out} holds {n - missing} of trials 0..{n - 1}",
                   err=True)


def _still_missing(job: CollectJob, out: Path) -> int:
    """How many of ``job``'s trials ``out`` lacks now (read again after the run)."""
    from dataclasses import replace

    from ltamp_cli.seeds import usable_seed
    from ltamp_cli.trials.collect import pending_indices, with_setup
    from ltamp_cli.trials.record import TrialDataset

    try:
        job = with_setup(replace(job, seed=usable_seed(job.seed)))
        return len(pending_indices(TrialDataset(out), job))
    except InputError as error:  # the file now holds another job's trials
        typer.echo(f"ltamp: warning: {error}", err=True)
        return job.n
