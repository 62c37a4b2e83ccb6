"""Two ``ltamp train`` into one ``--out`` at once, and a ``collect`` into the trial file of a
model being trained: one writer at a time, every trial once, the model whole. (Held: the
directory lock; the collect is refused by the trial file's own lock, new in round 2.)"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.trials.record import TrialDataset

REPO = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
BUDGET = 25


def _start(cwd: Path, *argv: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "ltamp_cli", *argv], cwd=cwd, env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_two_trains_into_one_out(tmp_path: Path) -> None:
    train = ("train", "moving2d", "--backend", "synthetic", "--strategy", "lse",
             "--budget", str(BUDGET), "--init", "5", "--out", "m")
    first = _start(tmp_path, *train)
    trials = tmp_path / "m" / "trials.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (trials.exists() and trials.stat().st_size):
        time.sleep(0.05)
    second = _start(tmp_path, *train)
    collect = _start(tmp_path, "collect", "moving2d", "--backend", "synthetic", "-n", "50",
                     "--out", str(trials))
    results = [(p.wait(timeout=600), p.stderr.read()) for p in (first, second, collect)]
    assert results[0][0] == 0, results[0][1][-800:]
    for code, err in results[1:]:
        lines = err.strip().splitlines()
        # refused while the first runs (one line), or, had it finished, a no-op resume
        assert code in (0, 2) and "Traceback" not in err, err[-800:]
        if code == 2:
            assert len(lines) == 1 and "being written by another" in lines[0], lines
    assert results[1][0] == 2 or results[2][0] == 2, "neither second writer met the lock"
    counts = Counter(r.index for r in TrialDataset(trials).read())
    assert max(counts.values()) == 1
    if results[2][0] != 0:  # collect refused: exactly the training's trials
        assert set(counts) == set(range(BUDGET))
    loaded = load_model(tmp_path / "m")
    assert loaded.metadata["training"]["n_trials"] == loaded.model.gp.n >= BUDGET
