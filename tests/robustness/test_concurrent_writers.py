"""Two writers of one trial file, however the file is named, and collection killed then
resumed: nothing lost, nothing duplicated, no torn line read as data.

Before the fix, ``ltamp collect --out a.jsonl`` and ``--out link.jsonl`` (a symlink to
``a.jsonl``) took two different locks and both wrote every trial (799 lines, 399
duplicates for ``-n 400``); ``collect`` also drew its progress bar into logs and under
``-q``.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.trials.record import TrialDataset
from ltamp_cli.writer_lock import exclusive_writer

REPO = Path(__file__).resolve().parents[2]


def _collect(out: Path, n: int, *extra: str) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
    return subprocess.Popen(
        [sys.executable, "-m", "ltamp_cli", *extra, "collect", "moving2d", "--backend",
         "synthetic", "-n", str(n), "--out", str(out)],
        cwd=out.parent, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        # a test run started in the background of a non-interactive shell ignores SIGINT,
        # and children inherit that: the interrupted collect must see Ctrl-C as a user's does
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _indices(path: Path) -> Counter[int]:
    return Counter(record.index for record in TrialDataset(path).read())


def test_a_symlink_to_a_held_output_finds_its_lock(tmp_path: Path) -> None:
    target = tmp_path / "a.jsonl"
    link = tmp_path / "link.jsonl"
    link.symlink_to(target.name)
    alias = tmp_path / "sub" / ".." / "a.jsonl"
    (tmp_path / "sub").mkdir()
    with exclusive_writer(target, is_directory=False):
        for other in (link, alias):
            with pytest.raises(InputError, match="being written by another"), \
                    exclusive_writer(other, is_directory=False):
                pass
    model = tmp_path / "model"
    model.mkdir()
    (tmp_path / "model-link").symlink_to("model")
    with exclusive_writer(model, is_directory=True), \
            pytest.raises(InputError, match="being written by another"), \
            exclusive_writer(tmp_path / "model-link", is_directory=True):
        pass


def test_two_collects_through_a_symlink_write_each_trial_once(tmp_path: Path) -> None:
    target = tmp_path / "a.jsonl"
    (tmp_path / "link.jsonl").symlink_to(target.name)
    first = _collect(target, 300)
    second = _collect(tmp_path / "link.jsonl", 300)
    outcomes = [process.communicate(timeout=300) for process in (first, second)]
    codes = [first.returncode, second.returncode]
    assert sorted(codes) in ([0, 0], [0, 2]), (codes, outcomes)
    for code, (_out, err) in zip(codes, outcomes, strict=True):
        lines = err.strip().splitlines()
        assert "trial/s" not in err, "progress drawn into a pipe"
        if code == 2:
            assert len(lines) == 1 and "being written by another" in lines[0], lines
    counts = _indices(target)
    assert set(counts) == set(range(300)) and max(counts.values()) == 1


@pytest.mark.parametrize("how", [signal.SIGINT, signal.SIGKILL])
def test_interrupted_collect_resumes_without_loss_or_duplicates(tmp_path: Path,
                                                                how: signal.Signals) -> None:
    out = tmp_path / "trials.jsonl"
    process = _collect(out, 3000)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and (not out.exists() or out.stat().st_size < 4000):
        time.sleep(0.05)
    process.send_signal(how)
    _out, err = process.communicate(timeout=120)
    if how == signal.SIGINT:
        assert process.returncode == 130 and err.strip().splitlines()[-1] == \
            "ltamp: interrupted", err[-300:]
    before = _indices(out)
    assert 0 < len(before) < 3000 and max(before.values()) == 1
    # a torn last line, as a kill in the middle of a write would leave it
    with out.open("ab") as handle:
        handle.write(b'{"backend": "synthetic", "context": [0.5')
    assert _indices(out) == before  # the torn line is not data
    resumed = _collect(out, 3000)
    _out, err = resumed.communicate(timeout=600)
    assert resumed.returncode == 0, err[-500:]
    after = _indices(out)
    assert set(after) == set(range(3000)) and max(after.values()) == 1
    lines = out.read_bytes().split(b"\n")
    assert lines[-1] == b"" and all(json.loads(line) for line in lines[:-1])
    # the trials kept from before the interruption are unchanged, byte for byte
    first = {json.loads(line)["index"]: line for line in lines[:len(before)]}
    assert set(first) == set(before)


def test_a_dangling_symlink_output_is_created_through_and_cleaned_up(tmp_path: Path) -> None:
    # Before: the file lock opened the link itself with O_EXCL ("File exists") when the
    # link's collect took the lock first, and releasing would have removed the link.
    (tmp_path / "link.jsonl").symlink_to("a.jsonl")
    with exclusive_writer(tmp_path / "link.jsonl", is_directory=False):
        assert (tmp_path / "a.jsonl").is_file()
        with pytest.raises(InputError, match="being written by another"), \
                exclusive_writer(tmp_path / "a.jsonl", is_directory=False):
            pass
    assert (tmp_path / "link.jsonl").is_symlink() and not (tmp_path / "a.jsonl").exists()
