"""Ask/tell learning: ``ltamp train --ask`` proposes, ``ltamp tell`` records and refits."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig
from ltamp_cli.learning.ask_tell import PENDING_FILE, ask, tell
from ltamp_cli.learning.metrics import SkillEvaluator
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.trials.record import TrialDataset


def run(capsys, *argv: str) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as done:
        main(list(argv))
    captured = capsys.readouterr()
    return int(done.value.code or 0), captured.out, captured.err


def _true(synthetic, proposal) -> float:
    context = np.array(list(proposal["context"].values()))
    control = np.array(list(proposal["control"].values()))
    return float(synthetic.true_score("moving2d", context[None], control[None])[0])


def test_cli_ask_tell_round_trip(capsys, synthetic, tmp_path):
    out = tmp_path / "robot"
    code, _, err = run(capsys, "tell", str(out), "--score", "1")
    assert code == 2 and "no pending trial" in err and "Traceback" not in err
    ask = ("train", "--json", "moving2d", "--ask", "--out", str(out), "--init", "3")
    code, stdout, _ = run(capsys, *ask)
    assert code == 0
    first = json.loads(stdout)
    assert set(first["control"]) == {"x", "y"} and set(first["context"]) == {"phase"}
    assert (out / PENDING_FILE).is_file() and not (out / "trials.jsonl").exists()
    # Asking again before telling repeats the same pending trial.
    _, again, _ = run(capsys, *ask)
    assert json.loads(again) == first
    code, _, _ = run(capsys, "tell", str(out), "--score", "-0.5", "--invalid")
    assert code == 0 and not (out / PENDING_FILE).exists()
    [record] = TrialDataset(out / "trials.jsonl").read()
    assert record.score == -0.5 and record.valid is False
    assert record.control == (first["control"]["x"], first["control"]["y"])
    assert load_model(out).metadata["training"]["n_trials"] == 1
    code, _, err = run(capsys, "tell", str(out), "--score", "1")
    assert code == 2 and "no pending trial" in err


def test_tell_after_crash_does_not_duplicate(synthetic, tmp_path):
    config = LearningConfig(strategy="lse2", init=2, seed=5)
    proposal = ask(synthetic, "moving2d", config, tmp_path)
    pending = (tmp_path / PENDING_FILE).read_text()
    tell(tmp_path, 0.3)
    # Simulate a crash after the append but before pending.json was removed.
    (tmp_path / PENDING_FILE).write_text(pending)
    tell(tmp_path, 0.3)
    records = TrialDataset(tmp_path / "trials.jsonl").read()
    assert [r.index for r in records] == [proposal.index] == [0]


def test_tell_rejects_non_finite_score(synthetic, tmp_path):
    ask(synthetic, "moving2d", LearningConfig(init=2), tmp_path)
    with pytest.raises(InputError, match="finite"):
        tell(tmp_path, float("nan"))
    assert (tmp_path / PENDING_FILE).is_file()


def test_forty_tells_with_the_true_score_learn_moving2d(synthetic, tmp_path):
    config = LearningConfig(strategy="lse2", init=10, seed=0)
    for _ in range(40):
        proposal = ask(synthetic, "moving2d", config, tmp_path).to_json()
        tell(tmp_path, _true(synthetic, proposal))
    evaluator = SkillEvaluator.synthetic(synthetic, "moving2d", n_test=3000, seed=99)
    f1 = evaluator.heldout.f1(load_model(tmp_path).model)
    # Fixed seed: lse2 reaches 0.94 here, plain GP on random trials 0.83-0.89 (seeds 0-3).
    assert f1 >= 0.9, f1
    records = TrialDataset(tmp_path / "trials.jsonl").read()
    assert [r.index for r in records] == list(range(40))
