"""``ltamp train`` killed (SIGKILL) at random moments resumes without losing or repeating trials."""

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
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.trials.record import TrialDataset, TrialRecord

BUDGET = 25
SEED = 2
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _command(out: Path) -> list[str]:
    # ``lse`` (a continuous straddle search per trial): ``lse2``'s 100-candidate proposal is
    # so fast on the synthetic skill that all 25 trials are written within a kill's delay.
    return [
        sys.executable, "-m", "ltamp_cli", "train", "moving2d", "--backend", "synthetic",
        "--strategy", "lse", "--budget", str(BUDGET), "--init", "5", "--seed", str(SEED),
        "--out", str(out),
    ]  # fmt: skip


def _check_prefix(records: list[TrialRecord]) -> None:
    """Trials are 0..k-1 exactly once, each with its own seed (no loss, no duplicate)."""
    assert [r.index for r in records] == list(range(len(records)))
    assert len({r.seed for r in records}) == len(records)


def _run_and_kill(out: Path, at_trials: int, delay_s: float) -> int:
    """Start training, SIGKILL it ``delay_s`` after OUT/trials.jsonl holds ``at_trials`` lines.

    Returns the process's exit code (``-SIGKILL`` when the kill landed).
    """
    trials = TrialDataset(out / "trials.jsonl")
    process = subprocess.Popen(
        _command(out), env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        start_new_session=True,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while process.poll() is None and time.monotonic() < deadline:
        if len(trials.read()) >= at_trials:
            break
        time.sleep(0.02)
    time.sleep(delay_s)
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGKILL)
    return process.wait(timeout=30)


@pytest.mark.slow
def test_train_killed_at_random_moments_resumes_exactly(tmp_path: Path) -> None:
    out = tmp_path / "model"
    rng = np.random.default_rng(20261121)
    # Three kills mid-way (after k trials plus a random fraction of a trial) ...
    kill_points = sorted(int(k) for k in rng.choice(np.arange(2, BUDGET - 3), 3, replace=False))
    landed = midway = 0
    kept: list[TrialRecord] = []
    for at_trials in kill_points:
        code = _run_and_kill(out, at_trials, float(rng.uniform(0.0, 0.3)))
        records = TrialDataset(out / "trials.jsonl").read()
        _check_prefix(records)
        # What an earlier run appended is never rewritten or repeated.
        assert [r.to_json() for r in records[: len(kept)]] == [r.to_json() for r in kept]
        kept = records
        if code == -signal.SIGKILL:
            landed += 1
            # A fast proposal may write the last trial within the delay; the kill then lands
            # in the final fit, which the resume must survive too.
            assert at_trials <= len(records) <= BUDGET
            midway += len(records) < BUDGET
    assert landed == len(kill_points), "every kill should land before training ends"
    assert midway >= 1, "at least one kill should land between trials"
    # ... and one after the last trial is written (final fit or model save), if still running.
    _run_and_kill(out, BUDGET, float(rng.uniform(0.0, 0.2)))

    done = subprocess.run(_command(out), env=ENV, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    records = TrialDataset(out / "trials.jsonl").read()
    assert len(records) == BUDGET
    _check_prefix(records)
    assert [r.to_json() for r in records[: len(kept)]] == [r.to_json() for r in kept]

    loaded = load_model(out)
    assert loaded.metadata["training"]["n_trials"] == BUDGET
    assert loaded.metadata["n_train"] == BUDGET
    # The reloaded model is the trained one: it mostly agrees with the true good set.
    test_rng = np.random.default_rng(0)
    contexts = test_rng.uniform(0.0, 1.0, size=(400, 1))
    controls = test_rng.uniform([0.0, -1.0], [4.0, 1.0], size=(400, 2))
    truth = load_backend("synthetic").true_score("moving2d", contexts, controls) > 0
    labels = loaded.model.predict_labels(contexts, controls)
    f1 = 2 * np.sum(labels & truth) / (labels.sum() + truth.sum())
    assert 0 < truth.sum() < 400 and f1 >= 0.5  # 25 trials reach ~0.87 uninterrupted
