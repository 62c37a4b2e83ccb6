"""A pool of trials is learned from, or a trial file resumed, only if its records are the
kind of trial the backend runs now: its backend tag, robot setup and physics (issue #20:
the scoop's 5-iteration ``pybullet@v1`` trials must never train a ``pybullet@v1.1`` model).

``ltamp train --data POOL`` and the Python API (``learn_from_pool``) refuse another kind in
one line naming the record (``file:line`` or ``pool record i``) and both values, exit 2;
``collect``'s pending count (``pending_indices`` with the job as ``with_setup`` fills it)
does too. Records imported from outside any simulator are let in, as before.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig, learn_from_pool
from ltamp_cli.trials.collect import CollectJob, pending_indices, with_setup
from ltamp_cli.trials.physics import TrialKind
from ltamp_cli.trials.record import TrialDataset, TrialRecord

SCOOP_CONTEXT = (0.2, 0.08, 0.12, 0.2)
SCOOP_CONTROL = (0.2, -0.2, 0.0, 0.0, 0.02)
CURRENT = "pybullet@v1.1"  # the scoop's physics since its 50 solver iterations


def scoop(index: int, physics: str | None = CURRENT, backend: str = "pybullet",
          setup: str | None = None, score: float = -0.5) -> TrialRecord:
    return TrialRecord(skill="scoop", context=SCOOP_CONTEXT,
                       control=(SCOOP_CONTROL[0] + 0.01 * index, *SCOOP_CONTROL[1:]),
                       score=score, valid=True, seed=index, backend=backend, index=index,
                       setup=setup, physics=physics)


def write(path: Path, records: list[TrialRecord], blank_after: int | None = None) -> Path:
    lines = [r.to_json() for r in records]
    if blank_after is not None:
        lines.insert(blank_after, "")
    path.write_text("\n".join(lines) + "\n")
    return path


def train_pool(pool: Path, out: Path, capsys: pytest.CaptureFixture[str],
               *extra: str) -> tuple[int, list[str]]:
    with pytest.raises(SystemExit) as done:
        main(["train", "scoop", "--backend", "pybullet", "--data", str(pool), "--strategy",
              "random", "--budget", "4", "--init", "4", "--out", str(out), *extra])
    err = capsys.readouterr().err
    return int(done.value.code or 0), [line for line in err.splitlines() if line.strip()]


def test_the_backends_physics_of_the_scoop_is_the_50_iteration_revision() -> None:
    backend = load_backend("pybullet")
    try:
        assert TrialKind.of_backend(backend, "scoop") == TrialKind("pybullet", None, CURRENT)
    finally:
        backend.close()


def test_train_refuses_a_pool_of_another_physics_at_its_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # Line 1 current, line 2 blank, line 3 a 5-iteration trial written before the field.
    pool = write(tmp_path / "pool.jsonl", [scoop(0), scoop(1, physics=None), scoop(2)],
                 blank_after=1)
    code, lines = train_pool(pool, tmp_path / "m", capsys)
    assert code == 2 and len(lines) == 1, lines
    assert f"{pool}:3: " in lines[0], lines
    assert "physics pybullet@v1, not pybullet@v1.1" in lines[0]
    assert not (tmp_path / "m" / "model.json").exists()


def test_train_refuses_a_pool_of_another_robot_setup_or_backend(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    robot = write(tmp_path / "robot.jsonl",
                  [scoop(0, backend="pybullet+panda", setup="panda-r3")])
    code, lines = train_pool(robot, tmp_path / "m", capsys)
    assert code == 2 and len(lines) == 1, lines
    assert f"{robot}:1: " in lines[0]
    assert "backend pybullet+panda, not pybullet" in lines[0]
    assert "setup 'panda-r3', not no recorded setup" in lines[0]
    sapien = write(tmp_path / "sapien.jsonl", [scoop(0, physics="sapien@v3", backend="sapien")])
    code, lines = train_pool(sapien, tmp_path / "m", capsys)
    assert code == 2 and len(lines) == 1, lines
    assert "backend sapien, not pybullet" in lines[0] and "sapien@v3" in lines[0]


def test_train_learns_from_a_pool_of_the_backends_kind(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    records = [scoop(i, score=0.5 if i % 2 else -0.5) for i in range(4)]
    imported = TrialRecord(skill="scoop", context=SCOOP_CONTEXT, control=SCOOP_CONTROL,
                           score=0.3, valid=True, seed=9, backend="import:robot.csv")
    pool = write(tmp_path / "pool.jsonl", [*records, imported])
    code, lines = train_pool(pool, tmp_path / "m", capsys, "--budget", "5", "--init", "5")
    assert code == 0, lines
    assert (tmp_path / "m" / "model.json").is_file()


def test_the_python_api_refuses_a_pool_of_two_kinds() -> None:
    spec = load_backend("pybullet").skills()["scoop"]
    config = LearningConfig(strategy="random", budget=3, init=3, seed=0)
    with pytest.raises(InputError, match=r"pool record 2: .*physics pybullet@v1\.1\+solver5, "
                                         r"not pybullet@v1\.1"):
        learn_from_pool(spec, [scoop(0), scoop(1), scoop(2, physics="pybullet@v1.1+solver5")],
                        config)
    with pytest.raises(InputError, match=r"pool record 0: .*physics pybullet@v1\.1, not "
                                         r"pybullet@v9"):
        learn_from_pool(spec, [scoop(0), scoop(1)], config,
                        kind=TrialKind("pybullet", None, "pybullet@v9"))


def test_collects_pending_count_refuses_a_file_of_another_physics(tmp_path: Path) -> None:
    dataset = TrialDataset(tmp_path / "scoop.jsonl")
    dataset.append([scoop(5), scoop(6, physics=None)])  # indices beyond n: no seed check
    job = with_setup(CollectJob(skill="scoop", backend="pybullet", n=2))
    assert job.physics == CURRENT
    with pytest.raises(InputError, match=r"scoop\.jsonl:2: .*physics pybullet@v1, not "
                                         r"pybullet@v1\.1"):
        pending_indices(dataset, job)
    current = TrialDataset(tmp_path / "current.jsonl")
    current.append(scoop(5))
    assert pending_indices(current, job) == [0, 1]


def run_cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str]]:
    with pytest.raises(SystemExit) as done:
        main(argv)
    err = capsys.readouterr().err
    return int(done.value.code or 0), [line for line in err.splitlines() if line.strip()]


def test_held_out_trials_of_another_physics_are_refused_by_evaluate_and_train(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """F1 against labels of another physics measures nothing about the model: `evaluate
    --data` and `train --test-data` refuse such held-out files as `train --data` does."""
    current = write(tmp_path / "pool.jsonl",
                    [scoop(i, score=0.5 if i % 2 else -0.5) for i in range(4)])
    code, lines = train_pool(current, tmp_path / "m", capsys)
    assert code == 0, lines
    stale = write(tmp_path / "stale.jsonl", [scoop(0), scoop(1, physics=None)])
    code, lines = run_cli(["evaluate", str(tmp_path / "m"), "--data", str(stale),
                           "--trials", "0", "--json"], capsys)
    assert code == 2 and len(lines) == 1, lines
    assert f"{stale}:2: " in lines[0] and "physics pybullet@v1, not pybullet@v1.1" in lines[0]
    code, lines = train_pool(current, tmp_path / "m2", capsys, "--test-data", str(stale),
                             "--eval-every", "2")
    assert code == 2 and len(lines) == 1, lines
    assert f"{stale}:2: " in lines[0] and "physics pybullet@v1, not pybullet@v1.1" in lines[0]
    code, lines = run_cli(["evaluate", str(tmp_path / "m"), "--data", str(current),
                           "--trials", "0", "--json"], capsys)
    assert code == 0, lines
