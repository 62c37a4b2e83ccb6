"""Round 3: ``ltamp collect --workers N`` interrupted. Every index was queued for the workers
up front; with more than the pipe holds (``-n 20000``) the queue's feeder thread stayed
blocked writing to the pipe after the workers were stopped, and the interpreter waited for it
at exit: Ctrl-C (SIGINT to the process group) or ``kill -INT`` left ``collect`` hanging
forever (and holding the file's writer lock). Now it exits 130 at once and a resume fills
exactly the missing indices."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import pytest

from ltamp_cli.trials.record import TrialDataset

REPO = Path(__file__).resolve().parents[2]


def _collect(out: Path, n: int) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
    return subprocess.Popen(
        [sys.executable, "-m", "ltamp_cli", "collect", "moving2d", "--backend", "synthetic",
         "-n", str(n), "--out", str(out), "--workers", "2"],
        cwd=out.parent, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True,
        # a test run started in the background of a non-interactive shell ignores SIGINT,
        # and children inherit that: the interrupted collect must see Ctrl-C as a user's does
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _indices(path: Path) -> Counter[int]:
    return Counter(record.index for record in TrialDataset(path).read())


@pytest.mark.parametrize("group", [True, False], ids=["ctrl-c", "kill-int"])
def test_interrupted_parallel_collect_exits_and_resumes(tmp_path: Path, group: bool) -> None:
    out = tmp_path / "trials.jsonl"
    process = _collect(out, 20000)
    deadline = time.monotonic() + 180
    while time.monotonic() < deadline and (not out.exists() or out.stat().st_size < 20000):
        time.sleep(0.05)
    if group:
        os.killpg(process.pid, signal.SIGINT)
    else:
        process.send_signal(signal.SIGINT)
    try:
        _out, err = process.communicate(timeout=90)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        pytest.fail("collect --workers 2 still running 90 s after SIGINT")
    assert process.returncode == 130, err[-300:]
    assert err.strip().splitlines()[-1] == "ltamp: interrupted", err[-300:]
    before = _indices(out)
    assert before and max(before.values()) == 1
    top = max(before) + 1  # trials finish out of order: fill the holes below the highest
    resumed = _collect(out, top)
    _out, err = resumed.communicate(timeout=600)
    assert resumed.returncode == 0, err[-500:]
    after = _indices(out)
    assert set(after) == set(range(top)) and max(after.values()) == 1
