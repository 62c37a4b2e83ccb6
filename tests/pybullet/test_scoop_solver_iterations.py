"""The 3D scoop's PyBullet world runs the reference's 50 solver iterations (issues #20/#21),
under its own physics revision, so trials of the old 5-iteration physics (files written
before, without a physics field) never share a file with new ones."""

from __future__ import annotations

from pathlib import Path

import pybullet as p
import pytest

from ltamp_cli.backends.pybullet.backend import Kitchen3DBackend
from ltamp_cli.backends.pybullet.world import (
    SKILL_SOLVER_ITERATIONS,
    physics_version,
    skill_world_config,
)
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.trials.collect import CollectJob, collect
from ltamp_cli.trials.record import TrialDataset, TrialRecord


def old_scoop_record(index: int) -> TrialRecord:
    """A 5-iteration scoop trial as files written before the switch hold it (no physics)."""
    return TrialRecord(skill="scoop", context=(0.2, 0.08, 0.12, 0.15),
                       control=(0.2, -0.2, 0.0, 0.0, 0.02), score=-0.5, valid=True,
                       seed=index, backend="pybullet", index=index)


def test_the_scoop_world_steps_with_50_solver_iterations_and_the_others_with_5() -> None:
    assert skill_world_config("scoop").solver_iterations == 50
    assert {s: skill_world_config(s).solver_iterations for s in ("pour", "push", "stir")} == {
        "pour": 5, "push": 5, "stir": 5}
    assert set(SKILL_SOLVER_ITERATIONS) == {"pour", "scoop", "push", "stir"}
    backend = Kitchen3DBackend()
    try:
        for skill, expected in (("scoop", 50), ("pour", 5)):
            client = backend.world_for(skill).client
            # What Bullet itself was told, not only our config.
            assert p.getPhysicsEngineParameters(physicsClientId=client)[
                "numSolverIterations"] == expected
        assert backend.world_for("scoop") is not backend.world_for("pour")
    finally:
        backend.close()


def test_the_scoop_has_its_own_physics_revision_and_5_iterations_are_a_what_if() -> None:
    assert physics_version("scoop") == "1.1" and physics_version("pour") == "1"
    shipped, old = Kitchen3DBackend(), Kitchen3DBackend(solver_iterations=5)
    try:
        assert shipped.physics_tag("scoop") == "pybullet@v1.1"
        assert old.physics_tag("scoop") == "pybullet@v1.1+solver5"
        assert old.physics_tag("pour") == shipped.physics_tag("pour") == "pybullet@v1"
        assert old.world_config("scoop").solver_iterations == 5
    finally:
        shipped.close()
        old.close()


def test_collect_refuses_to_resume_a_file_of_5_iteration_scoop_trials(tmp_path: Path) -> None:
    out = tmp_path / "scoop.jsonl"
    TrialDataset(out).append(old_scoop_record(0))
    with pytest.raises(InputError, match=r"physics pybullet@v1, not pybullet@v1\.1"):
        collect(CollectJob(skill="scoop", backend="pybullet", n=2), out, progress=False)
    assert len(TrialDataset(out).read()) == 1  # nothing ran, nothing was appended


def test_train_refuses_a_model_folder_of_5_iteration_scoop_trials(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    TrialDataset(tmp_path / "m" / "trials.jsonl").append(old_scoop_record(0))
    with pytest.raises(SystemExit) as done:
        main(["train", "scoop", "--backend", "pybullet", "--budget", "2", "--init", "2",
              "--out", str(tmp_path / "m")])
    err = capsys.readouterr().err
    assert done.value.code == 2 and len(err.strip().splitlines()) == 1, err
    assert "pybullet@v1, not pybullet@v1.1" in err


def test_the_fidelity_solver_row_still_compares_the_scoop_at_5_with_50() -> None:
    from bench import fidelity

    row = {r.name: r for r in fidelity.ROWS}["3d-scoop-solver"]
    built = [fidelity.SETTINGS[name]() for name in (row.fast, row.reference)]
    try:
        assert [b.world_config("scoop").solver_iterations for b in built] == [5, 50]
    finally:
        for backend in built:
            backend.close()
