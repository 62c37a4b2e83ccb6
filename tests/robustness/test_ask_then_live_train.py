"""A live run in an ask/tell directory must not take the pending proposal's index.

Round 7: ``ltamp train --ask --out D`` proposed trial 0; ``ltamp train --out D`` (live,
resumed in the same directory) appended its own trials 0, 1, 2; then ``ltamp tell D
--score 0.7`` found "trial 0" in the file, took it for its own (the guard against a crash
between appending and clearing pending.json compared indices only), recorded nothing,
refitted, removed pending.json and reported success: the real trial's result was lost
without a word. A live run now refuses while a proposal is pending, and ``tell`` refuses an
index held by another trial.
"""

from __future__ import annotations

import io
import json
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import replace
from pathlib import Path

import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.ask_tell import ask, tell
from ltamp_cli.trials.record import TrialDataset

SKILL = "flick2d"


def _ask(directory: Path) -> None:
    ask(load_backend("synthetic"), SKILL, LearningConfig(budget=5, init=5, seed=0), directory)


def test_a_live_run_refuses_a_pending_proposal(tmp_path: Path) -> None:
    _ask(tmp_path)
    dataset = TrialDataset(tmp_path / "trials.jsonl")
    with pytest.raises(InputError, match=r"pending.json: a trial proposed by .* is pending"):
        learn_online(load_backend("synthetic"), SKILL,
                     LearningConfig(budget=3, init=5, seed=0), dataset)  # before: 3 trials
    assert not dataset.path.exists()
    record = tell(tmp_path, 0.7)
    assert [(r.index, r.score) for r in dataset.read()] == [(0, 0.7)] == [(record.index, 0.7)]
    # told: the live run resumes after it
    result = learn_online(load_backend("synthetic"), SKILL,
                          LearningConfig(budget=2, init=5, seed=0), dataset)
    assert [r.index for r in result.records] == [0, 1]


def test_the_cli_refuses_in_one_line(tmp_path: Path) -> None:
    _ask(tmp_path)
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err), \
            pytest.raises(SystemExit) as done:
        main(["train", SKILL, "--backend", "synthetic", "--out", str(tmp_path),
              "--budget", "3", "--init", "3"])
    lines = err.getvalue().strip().splitlines()
    assert done.value.code == 2 and len(lines) == 1, lines
    assert "pending" in lines[0] and not (tmp_path / "trials.jsonl").exists()


def test_tell_refuses_an_index_another_trial_holds(tmp_path: Path) -> None:
    # The same state written by another tool (or an older ltamp): the proposal's index is
    # taken by a different trial.
    _ask(tmp_path)
    pending = json.loads((tmp_path / "pending.json").read_text())["proposal"]
    other = TrialDataset(tmp_path / "other.jsonl")
    learn_online(load_backend("synthetic"), SKILL, LearningConfig(budget=1, init=5, seed=3),
                 other)
    (stranger,) = other.read()
    assert stranger.index == pending["index"] and stranger.seed != pending["seed"]
    dataset = TrialDataset(tmp_path / "trials.jsonl")
    dataset.append(replace(stranger, seed=pending["seed"]))  # even with the proposal's seed
    before = dataset.path.read_bytes()
    with pytest.raises(InputError, match="trial 0 is already recorded, and it is not the "
                                         "pending trial"):
        tell(tmp_path, 0.7)  # before: returned as recorded, nothing written
    assert dataset.path.read_bytes() == before and (tmp_path / "pending.json").is_file()


def test_a_repeated_tell_after_a_crash_records_once(tmp_path: Path) -> None:
    _ask(tmp_path)
    saved = (tmp_path / "pending.json").read_bytes()
    tell(tmp_path, 0.7)
    (tmp_path / "pending.json").write_bytes(saved)  # the crash: appended, not cleared
    record = tell(tmp_path, 0.7)
    assert record.index == 0
    assert [r.index for r in TrialDataset(tmp_path / "trials.jsonl").read()] == [0]
