"""A model trained on robot-in-the-loop trials, evaluated; a pool of several skills refused
at the right record (red-team round 8).

* ``ltamp train --robot panda`` saves the model's backend as its trials' tag,
  ``pybullet+panda``; ``ltamp evaluate`` loaded that tag as a backend's name and stopped at
  "unknown backend 'pybullet+panda'" (with or without ``--data``), so no robot model could
  be evaluated. (``ask``/``tell`` already split the tag.)
* ``learn_from_pool`` numbered its pool after dropping the other skills' trials: in a pool
  of pour and scoop trials, the refusal named the wrong "pool record".
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig, learn_from_pool
from ltamp_cli.trials.physics import TrialKind
from ltamp_cli.trials.record import TrialRecord


def push_records(kind: TrialKind, n: int, free: bool = False) -> list[TrialRecord]:
    """``n`` push trials of ``kind`` (``free``: the free-floating kind of the same physics),
    alternately successful, at points spread over the skill's box."""
    backend = load_backend("pybullet")
    try:
        spec = backend.skills()["push"]
    finally:
        backend.close()
    rng = np.random.default_rng(0)
    records = []
    for i in range(n):
        context = rng.uniform(spec.context.lows, spec.context.highs)
        control = rng.uniform(spec.control.lows, spec.control.highs)
        records.append(TrialRecord(
            skill="push", context=tuple(map(float, context)), control=tuple(map(float, control)),
            score=0.5 if i % 2 else -0.5, valid=True, seed=i, index=i,
            backend="pybullet" if free else kind.backend, setup=None if free else kind.setup,
            physics=kind.physics))
    return records


def write(path: Path, records: list[TrialRecord]) -> Path:
    path.write_text("".join(r.to_json() + "\n" for r in records))
    return path


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, list[str]]:
    with pytest.raises(SystemExit) as done:
        main(argv)
    captured = capsys.readouterr()
    return (int(done.value.code or 0), captured.out,
            [line for line in captured.err.splitlines() if line.strip()])


@pytest.fixture(scope="module")
def robot_kind() -> TrialKind:
    backend = load_backend("pybullet", robot="panda")
    try:
        return TrialKind.of_backend(backend, "push")
    finally:
        backend.close()


def test_a_robot_model_is_evaluated_on_robot_trials(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], robot_kind: TrialKind) -> None:
    assert robot_kind.backend == "pybullet+panda"
    pool = write(tmp_path / "pool.jsonl", push_records(robot_kind, 6))
    code, _out, lines = run(["train", "push", "--backend", "pybullet", "--robot", "panda",
                             "--data", str(pool), "--strategy", "random", "--budget", "6",
                             "--init", "6", "--out", str(tmp_path / "m")], capsys)
    assert code == 0, lines
    saved = json.loads((tmp_path / "m" / "model.json").read_text())
    assert saved["backend"] == "pybullet+panda"
    code, out, lines = run(["evaluate", str(tmp_path / "m"), "--data", str(pool), "--trials",
                            "0", "--json"], capsys)
    assert code == 0, lines
    report = json.loads(out)
    assert report["backend"] == "pybullet+panda" and report["n_test"] == 6
    # Free-floating trials are another kind: refused at their line, as by train --data.
    free = write(tmp_path / "free.jsonl", push_records(robot_kind, 2, free=True))
    code, _out, lines = run(["evaluate", str(tmp_path / "m"), "--data", str(free),
                             "--trials", "0"], capsys)
    assert code == 2 and len(lines) == 1, lines
    assert f"{free}:1: " in lines[0] and "backend pybullet, not pybullet+panda" in lines[0]


def test_a_pool_of_several_skills_names_the_record_it_refuses(robot_kind: TrialKind) -> None:
    backend = load_backend("pybullet")
    try:
        spec = backend.skills()["push"]
        free_kind = TrialKind.of_backend(backend, "push")
    finally:
        backend.close()
    pushes = push_records(free_kind, 3, free=True)
    pour = TrialRecord(skill="pour", context=(0.0,), control=(0.0,), score=-1.0, valid=False,
                       seed=9, backend="pybullet")
    stale = replace(pushes[2], physics="pybullet@v0")
    config = LearningConfig(strategy="random", budget=3, init=3, seed=0)
    with pytest.raises(InputError, match=r"^pool record 3: "):
        learn_from_pool(spec, [pushes[0], pour, pushes[1], stale], config)
