"""``ltamp train --refit`` killed (SIGKILL) at random moments: the directory is never read
as a valid model that mixes two fits, and rerunning ``--refit`` finishes the job with the
same result as an uninterrupted refit.

Before the fix a refit killed after it replaced ``weights.npz`` but before ``model.json``
(the save's last two steps) left a directory that ``--refit`` itself refused ("weights.npz
does not match model.json ... train again"): the refit loaded the old model first, though it
needs nothing of it but ``model.json`` and the trials.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.learning.model_dir import load_model

REPO = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1",
       "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _ltamp(*argv: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "ltamp_cli", *argv], cwd=cwd, env=ENV,
                          capture_output=True, text=True, timeout=600, check=False)


def _refit(out: Path) -> subprocess.CompletedProcess[str]:
    return _ltamp("train", "moving2d", "--out", str(out), "--refit", "--json", cwd=out.parent)


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    """A live-trained moving2d model and the hyperparameters an uninterrupted refit gives."""
    work = tmp_path_factory.mktemp("refit")
    done = _ltamp("train", "moving2d", "--backend", "synthetic", "--strategy", "lse2",
                  "--budget", "30", "--init", "8", "--seed", "4", "--out", "m", cwd=work)
    assert done.returncode == 0, done.stderr[-2000:]
    reference = work / "reference"
    shutil.copytree(work / "m", reference)
    refitted = _refit(reference)
    assert refitted.returncode == 0, refitted.stderr[-2000:]
    return work / "m", json.loads(refitted.stdout)["hyperparameters"]


def _copy(model: Path, where: Path) -> Path:
    copy = where / "model"
    shutil.copytree(model, copy)
    return copy


def test_refit_resumes_after_a_kill_between_weights_and_metadata(trained: tuple[Path, dict],
                                                                 tmp_path: Path) -> None:
    model, expected = trained
    out = _copy(model, tmp_path)
    # what a kill between the two replacements leaves: new weights, old model.json
    other = _copy(model, tmp_path / "other")
    assert _refit(other).returncode == 0
    (out / "weights.npz").write_bytes((other / "weights.npz").read_bytes())
    with pytest.raises(InputError, match="does not match"):
        load_model(out)  # never read as a valid model
    done = _refit(out)
    assert done.returncode == 0, done.stderr[-1000:]
    assert json.loads(done.stdout)["hyperparameters"] == expected
    assert load_model(out).metadata["hyperparameters"] == expected


@pytest.mark.slow
def test_refit_killed_at_random_moments_resumes_exactly(trained: tuple[Path, dict],
                                                        tmp_path: Path) -> None:
    model, expected = trained
    out = _copy(model, tmp_path)
    trials_before = (out / "trials.jsonl").read_bytes()
    rng = np.random.default_rng(20261127)
    landed = 0
    for delay in rng.uniform(0.2, 2.5, size=5):
        process = subprocess.Popen(
            [sys.executable, "-m", "ltamp_cli", "train", "moving2d", "--out", str(out),
             "--refit"], cwd=tmp_path, env=ENV, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, start_new_session=True)
        time.sleep(float(delay))
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
        landed += process.wait(timeout=60) == -signal.SIGKILL
        try:  # whatever the kill left is a consistent model or refused, never a mixture
            loaded = load_model(out)
        except InputError as error:
            assert "does not match" in str(error)
        else:
            assert loaded.metadata["n_train"] == loaded.model.gp.n == 30
        assert (out / "trials.jsonl").read_bytes() == trials_before  # trials untouched
    assert landed >= 1, "no kill landed while the refit ran"
    done = _refit(out)
    assert done.returncode == 0, done.stderr[-1000:]
    assert json.loads(done.stdout)["hyperparameters"] == expected
    loaded = load_model(out)
    assert loaded.metadata["training"]["n_trials"] == 30
    assert loaded.metadata["hyperparameters"] == expected
