"""Trial records name the physics they were simulated with (``TrialRecord.physics``), and a
file of one physics is never continued with another: ``collect`` and ``train`` refuse it in
one line, and pool archives keep each trial's own physics."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest

from bench.paper.pools import archive_pool, archived_record
from ltamp_cli.backends.pybullet.backend import Kitchen3DBackend
from ltamp_cli.backends.pybullet.world import physics_version
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.trials.collect import CollectJob, collect, pending_indices
from ltamp_cli.trials.physics import legacy_physics, record_physics
from ltamp_cli.trials.record import TrialDataset, TrialRecord

POUR_CONTEXT = (0.2, 0.08, 0.12, 0.07, 0.1, 0.06)
POUR_CONTROL = (-2.0, 0.0, 0.0, 0.1, 0.05)


def pour_record(index: int, physics: str | None = None) -> TrialRecord:
    return TrialRecord(skill="pour", context=POUR_CONTEXT, control=POUR_CONTROL, score=-1.0,
                       valid=True, seed=index, backend="pybullet", index=index,
                       physics=physics)


def test_records_carry_their_physics_and_older_ones_read_as_the_base_version() -> None:
    tagged = pour_record(0, "pybullet@v1")
    assert TrialRecord.from_dict(json.loads(tagged.to_json())) == tagged
    legacy = pour_record(1)
    assert "physics" not in json.loads(legacy.to_json())  # written as before the field
    assert record_physics(legacy) == legacy_physics("pybullet") == "pybullet@v1"
    assert legacy_physics("pybullet+panda") == "pybullet@v1"
    assert legacy_physics("box2d") is None
    with pytest.raises(TypeError, match="physics"):
        TrialRecord.from_dict({**json.loads(legacy.to_json()), "physics": 5})


def test_what_if_settings_are_part_of_the_tag() -> None:
    shipped, what_if = Kitchen3DBackend(), Kitchen3DBackend(solver_iterations=17,
                                                            contact_breaking_m={"push": 0.004})
    try:
        assert shipped.physics_tag("pour") == f"pybullet@v{physics_version('pour')}"
        assert what_if.physics_tag("pour") == f"pybullet@v{physics_version('pour')}+solver17"
        assert what_if.physics_tag("push").endswith("+solver17+breaking0.004m")
    finally:
        shipped.close()
        what_if.close()
    with pytest.raises(ValueError, match="solver iterations"):
        Kitchen3DBackend(solver_iterations=0)


def test_collected_records_name_their_physics_and_another_physics_is_refused(
        tmp_path: Path) -> None:
    out = tmp_path / "push.jsonl"  # a PyBullet push trial costs milliseconds
    assert collect(CollectJob(skill="push", backend="pybullet", n=1), out, progress=False) == 1
    (record,) = TrialDataset(out).read()
    assert record.physics == f"pybullet@v{physics_version('push')}"
    what_if = CollectJob(skill="push", backend="pybullet", n=2,
                         backend_options={"solver_iterations": 50})
    with pytest.raises(InputError, match=r"pybullet@v1\.1, not pybullet@v1\.1\+solver50"):
        collect(what_if, out, progress=False)
    assert len(TrialDataset(out).read()) == 1  # nothing ran, nothing was appended
    # The shipped setting resumes it.
    assert collect(CollectJob(skill="push", backend="pybullet", n=2), out, progress=False) == 1
    box2d = tmp_path / "box2d.jsonl"
    collect(CollectJob(skill="push", backend="box2d", n=1), box2d, progress=False)
    assert TrialDataset(box2d).read()[0].physics is None  # an unversioned engine


def test_older_records_of_the_current_base_version_resume(tmp_path: Path) -> None:
    dataset = TrialDataset(tmp_path / "pour.jsonl")
    dataset.append(pour_record(5))  # no physics field; index beyond n, so no seed check
    job = CollectJob(skill="pour", backend="pybullet", n=2)
    assert pending_indices(dataset, job, "pybullet@v1", same_physics=True) == [0, 1]
    with pytest.raises(InputError, match="physics pybullet@v1, not pybullet@v9"):
        pending_indices(dataset, job, "pybullet@v9", same_physics=True)


def test_train_refuses_a_model_folder_of_another_physics(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    TrialDataset(tmp_path / "m" / "trials.jsonl").append(pour_record(0, "pybullet@v0"))
    with pytest.raises(SystemExit) as done:
        main(["train", "pour", "--backend", "pybullet", "--budget", "2", "--init", "2",
              "--out", str(tmp_path / "m")])
    err = capsys.readouterr().err
    assert done.value.code == 2 and len(err.strip().splitlines()) == 1, err
    assert "physics pybullet@v0, not pybullet@v1" in err


def test_a_pool_archive_keeps_each_trials_own_physics(tmp_path: Path) -> None:
    archive = tmp_path / "pool.jsonl.gz"
    archive_pool([pour_record(0), pour_record(1, "pybullet@v0")], archive)
    with gzip.open(archive, "rt", encoding="utf-8") as handle:
        lines = [json.loads(line) for line in handle]
    assert [line["physics_version"] for line in lines] == ["pybullet@v1", "pybullet@v0"]
    assert all("physics" not in line for line in lines)
    assert [archived_record(line).physics for line in lines] == ["pybullet@v1", "pybullet@v0"]
    synthetic = {**lines[0], "backend": "synthetic", "physics_version": "synthetic@0.1.0"}
    assert archived_record(synthetic).physics is None  # unversioned: nothing to check
