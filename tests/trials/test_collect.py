"""Resumable parallel collection on the real Box2D backend."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.errors import InputError
from ltamp_cli.trials.collect import CollectJob, collect, run_one, trial_input, trial_seed
from ltamp_cli.trials.record import TrialDataset, TrialRecord


def _comparable(record: TrialRecord) -> tuple:
    return (record.index, record.context, record.control, record.score, record.valid, record.seed)


def test_trial_inputs_depend_only_on_seed_and_index() -> None:
    backend = load_backend("box2d")
    a = trial_input(backend, "pour", 11, 3)
    trial_input(backend, "pour", 11, 4)  # drawing other trials in between changes nothing
    b = trial_input(backend, "pour", 11, 3)
    assert np.array_equal(a.context, b.context) and np.array_equal(a.control, b.control)
    assert a.seed == b.seed == trial_seed(11, 3)
    c = trial_input(backend, "pour", 12, 3)
    assert not np.array_equal(a.control, c.control)


def test_valid_only_draws_valid_controls() -> None:
    backend = load_backend("box2d")
    items = [trial_input(backend, "push", 0, i, valid_only=True) for i in range(40)]
    controls = np.array([item.control for item in items])
    for item in items:
        assert backend.is_valid("push", item.context, item.control[None])[0]
    assert len({tuple(c) for c in controls}) == 40


def test_parallel_equals_serial(tmp_path: Path) -> None:
    job = CollectJob(skill="push", backend="box2d", n=12, seed=5)
    serial, parallel = tmp_path / "serial.jsonl", tmp_path / "parallel.jsonl"
    assert collect(job, serial, workers=1, progress=False) == 12
    assert collect(job, parallel, workers=2, progress=False) == 12
    a = sorted(map(_comparable, TrialDataset(serial).read()))
    b = sorted(map(_comparable, TrialDataset(parallel).read()))
    assert a == b and [r[0] for r in a] == list(range(12))
    assert collect(job, parallel, workers=2, progress=False) == 0  # nothing left to do


def test_resume_after_kill_loses_and_duplicates_nothing(tmp_path: Path) -> None:
    out = tmp_path / "pour.jsonl"
    n = 10
    command = [
        sys.executable, "-m", "ltamp_cli", "collect", "pour", "--backend", "box2d",
        "-n", str(n), "--workers", "2", "--seed", "3", "--out", str(out),
    ]  # fmt: skip
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    first = subprocess.Popen(
        command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        start_new_session=True,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(TrialDataset(out).read()) < 3:
        time.sleep(0.05)
    os.killpg(first.pid, signal.SIGKILL)  # the CLI and its workers, mid-way
    first.wait()
    partial = TrialDataset(out).read()
    assert 3 <= len(partial) < n, "the kill should land mid-way"

    subprocess.run(command, env=env, check=True, capture_output=True, timeout=300)
    records = TrialDataset(out).read()
    indices = sorted(record.index for record in records)
    assert indices == list(range(n))
    # The trials finished before the kill are kept verbatim and not run again.
    assert [r.to_json() for r in records[: len(partial)]] == [r.to_json() for r in partial]
    # A resumed trial is the same trial it would have been in an uninterrupted run.
    backend = load_backend("box2d")
    job = CollectJob(skill="pour", backend="box2d", n=n, seed=3)
    last = max(records[len(partial) :], key=lambda r: r.index)
    assert _comparable(run_one(backend, job, last.index)) == _comparable(last)


def test_refuses_file_of_another_job(tmp_path: Path) -> None:
    out = tmp_path / "push.jsonl"
    collect(CollectJob(skill="push", backend="box2d", n=2, seed=1), out, progress=False)
    with pytest.raises(InputError, match="different --seed"):
        collect(CollectJob(skill="push", backend="box2d", n=3, seed=2), out, progress=False)
    with pytest.raises(InputError, match="box2d/push"):
        collect(CollectJob(skill="pour", backend="box2d", n=3, seed=1), out, progress=False)
    with pytest.raises(InputError, match="no skill"):
        collect(CollectJob(skill="fly", backend="box2d", n=3), tmp_path / "x", progress=False)
    with pytest.raises(InputError, match="workers"):
        collect(CollectJob(skill="push", backend="box2d", n=3), out, workers=0, progress=False)
