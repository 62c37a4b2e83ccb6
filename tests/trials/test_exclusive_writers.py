"""One writer per trial file / model directory, no duplicate trials, workers die with collect."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ltamp_cli.writer_lock import exclusive_writer

REPO = Path(__file__).resolve().parents[2]


def _ltamp(*args: str, cwd: Path, **kwargs) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1",
           "XDG_CACHE_HOME": str(cwd / "cache")}
    return subprocess.run([sys.executable, "-m", "ltamp_cli", *args], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=180, **kwargs)


def _one_error_line(done: subprocess.CompletedProcess[str], *words: str) -> None:
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("ltamp: error:"), done.stderr
    assert all(word in lines[0] for word in words), lines[0]


COLLECT = ("collect", "moving2d", "--backend", "synthetic", "-n", "6", "--out", "t.jsonl")


def test_a_second_collect_on_one_file_is_refused_or_waits(tmp_path):
    with exclusive_writer(tmp_path / "t.jsonl", is_directory=False):
        _one_error_line(_ltamp(*COLLECT, cwd=tmp_path), "being written", "--wait")
        env = {**os.environ, "PYTHONPATH": str(REPO), "XDG_CACHE_HOME": str(tmp_path / "c")}
        waiting = subprocess.Popen([sys.executable, "-m", "ltamp_cli", *COLLECT, "--wait"],
                                   cwd=tmp_path, env=env, stderr=subprocess.PIPE, text=True)
        time.sleep(2.0)
        assert waiting.poll() is None  # still waiting for the lock
        # nothing written by the waiting collect (the holder creates the file empty)
        assert not (tmp_path / "t.jsonl").exists() or not (tmp_path / "t.jsonl").stat().st_size
    assert waiting.wait(timeout=120) == 0
    lines = (tmp_path / "t.jsonl").read_text().splitlines()
    assert sorted(json.loads(line)["index"] for line in lines) == list(range(6))


def test_resume_rejects_duplicate_trials_and_train_data_reports_them(tmp_path):
    assert _ltamp(*COLLECT, cwd=tmp_path).returncode == 0
    path = tmp_path / "t.jsonl"
    lines = path.read_text().splitlines()
    path.write_text("\n".join([*lines, lines[2]]) + "\n")  # what two writers used to do
    _one_error_line(_ltamp("collect", "moving2d", "--backend", "synthetic", "-n", "8",
                           "--out", "t.jsonl", cwd=tmp_path), "trial 2", "twice")
    trained = _ltamp("train", "moving2d", "--backend", "synthetic", "--data", "t.jsonl",
                     "--strategy", "random", "--budget", "6", "--init", "2", "--out", "m",
                     "--json", cwd=tmp_path)
    assert trained.returncode == 0, trained.stderr
    assert "repeats 1 trial record" in trained.stderr
    assert json.loads(trained.stdout)["n_trials"] == 6


def test_tell_is_refused_while_the_model_is_written_and_concurrent_tells_record_one_trial(
        tmp_path):
    from ltamp_cli.errors import InputError
    from ltamp_cli.learning.ask_tell import tell

    asked = _ltamp("train", "moving2d", "--backend", "synthetic", "--ask", "--out", "m",
                   cwd=tmp_path)
    assert asked.returncode == 0, asked.stderr
    with exclusive_writer(tmp_path / "m", is_directory=True), \
            pytest.raises(InputError, match="being written"):
        tell(tmp_path / "m", 0.77)  # what a `tell` beside a running `train` gets
    env = {**os.environ, "PYTHONPATH": str(REPO), "XDG_CACHE_HOME": str(tmp_path / "c"),
           "OMP_NUM_THREADS": "1"}
    tells = [subprocess.Popen([sys.executable, "-m", "ltamp_cli", "tell", "m", "--score",
                               str(score)], cwd=tmp_path, env=env, stderr=subprocess.PIPE,
                              text=True) for score in (0.1, 0.2, 0.3)]
    results = [(p.wait(timeout=180), p.stderr.read()) for p in tells]
    assert sorted(code for code, _ in results) == [0, 2, 2], results
    assert all("Traceback" not in err and err.count("\n") <= 1 for _, err in results)
    lines = (tmp_path / "m" / "trials.jsonl").read_text().splitlines()
    winner = next(score for (code, _), score in zip(results, (0.1, 0.2, 0.3), strict=True)
                  if code == 0)
    assert len(lines) == 1 and json.loads(lines[0])["score"] == winner


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(child) for child in text.split()]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_collect_workers_die_with_their_parent(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(REPO), "XDG_CACHE_HOME": str(tmp_path / "c")}
    parent = subprocess.Popen(
        [sys.executable, "-m", "ltamp_cli", "collect", "skill8d", "--backend", "synthetic",
         "-n", "300000", "--workers", "2", "--out", "t.jsonl"],
        cwd=tmp_path, env=env, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        workers: list[int] = []
        while time.monotonic() < deadline and len(workers) < 2:
            workers = _children(parent.pid)
            time.sleep(0.2)
        assert len(workers) >= 2, "workers never started"
        time.sleep(0.5)
        assert (tmp_path / "t.jsonl").exists()  # trials are running
    finally:
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=10)
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline and any(Path(f"/proc/{w}").exists() for w in workers):
        time.sleep(0.1)
    alive = [w for w in workers if Path(f"/proc/{w}").exists()
             and "Z" not in Path(f"/proc/{w}/stat").read_text().split()[2]]
    assert not alive, f"workers {alive} outlived their parent"


def test_live_training_refuses_to_resume_from_a_file_with_a_trial_twice(tmp_path):
    from ltamp_cli.backends import load_backend
    from ltamp_cli.learning.active import LearningConfig, learn_online
    from ltamp_cli.trials.record import TrialDataset

    backend = load_backend("synthetic")
    try:
        dataset = TrialDataset(tmp_path / "trials.jsonl")
        config = LearningConfig(strategy="random", budget=3, init=1, seed=0)
        learn_online(backend, "moving2d", config, dataset)
        lines = dataset.path.read_text().splitlines()
        dataset.path.write_text("\n".join([*lines, lines[0]]) + "\n")
        with pytest.raises(ValueError, match="recorded twice"):
            learn_online(backend, "moving2d", LearningConfig(strategy="random", budget=5,
                                                             init=1, seed=0), dataset)
    finally:
        backend.close()
