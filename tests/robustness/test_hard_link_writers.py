"""A hard link to a trial file another writer holds finds that writer's lock.

Before the fix the writer lock belonged to the (resolved) path only: ``ltamp collect --out
a.jsonl`` and ``--out other/b.jsonl`` (a hard link to ``a.jsonl``) took two different locks
and both appended every trial. The lock now also holds an OS lock on the file itself
(device + inode); a trial file that does not exist yet is created empty by its writer, so a
hard link made while it is written is recognised too, and removed again if left empty.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.trials.record import TrialDataset
from ltamp_cli.writer_lock import exclusive_writer

REPO = Path(__file__).resolve().parents[2]


def test_a_hard_link_to_a_held_output_finds_its_lock(tmp_path: Path) -> None:
    target = tmp_path / "a.jsonl"
    target.write_text("")
    (tmp_path / "other").mkdir()
    link = tmp_path / "other" / "b.jsonl"
    os.link(target, link)
    with exclusive_writer(target, is_directory=False):
        with pytest.raises(InputError, match="being written by another") as refused, \
                exclusive_writer(link, is_directory=False):
            pass
        assert "\n" not in str(refused.value)
    with exclusive_writer(link, is_directory=False):  # released: the link may write now
        pass


def test_a_hard_link_made_while_the_output_is_written_finds_its_lock(tmp_path: Path) -> None:
    target = tmp_path / "a.jsonl"
    link = tmp_path / "b.jsonl"
    with exclusive_writer(target, is_directory=False):
        os.link(target, link)  # the writer has not written anything yet
        with pytest.raises(InputError, match="being written by another"), \
                exclusive_writer(link, is_directory=False):
            pass


def test_a_writer_that_writes_nothing_leaves_no_file(tmp_path: Path) -> None:
    target = tmp_path / "a.jsonl"
    with exclusive_writer(target, is_directory=False):
        pass
    assert not target.exists()
    target.write_text("kept\n")
    with exclusive_writer(target, is_directory=False):
        pass
    assert target.read_text() == "kept\n"


def _collect(out: Path, n: int) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
    return subprocess.Popen(
        [sys.executable, "-m", "ltamp_cli", "collect", "moving2d", "--backend", "synthetic",
         "-n", str(n), "--out", str(out)],
        cwd=out.parent, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_two_collects_through_a_hard_link_write_each_trial_once(tmp_path: Path) -> None:
    target = tmp_path / "a.jsonl"
    target.write_text("")  # the file exists, so it can be linked
    (tmp_path / "other").mkdir()
    link = tmp_path / "other" / "b.jsonl"
    os.link(target, link)
    first, second = _collect(target, 300), _collect(link, 300)
    outcomes = [process.communicate(timeout=300) for process in (first, second)]
    codes = [first.returncode, second.returncode]
    assert sorted(codes) in ([0, 0], [0, 2]), (codes, outcomes)
    for code, (_out, err) in zip(codes, outcomes, strict=True):
        lines = err.strip().splitlines()
        assert "Traceback" not in err
        if code == 2:
            assert len(lines) == 1 and "being written by another" in lines[0], lines
    counts = Counter(record.index for record in TrialDataset(target).read())
    assert set(counts) == set(range(300)) and max(counts.values()) == 1
