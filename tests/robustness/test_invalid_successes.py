"""Trial records with ``"valid": false`` and a score > 0, as other tools write them: an
invalid trial is never a success whatever its score. Before the fix ``ltamp train --data``,
a resumed or refitted live run, ``ltamp evaluate --data``/``--test-data`` and the paper's
pool readers all learned or counted such a trial as a success (only ``import`` and ``tell``
refused it). The file itself is read as it is: nothing in it is changed or lost."""

from __future__ import annotations

import io
import json
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.protocol import ParamSpace, SkillSpec
from ltamp_cli.cli.app import main
from ltamp_cli.cli.train import heldout_from_records
from ltamp_cli.learning.active import LearningConfig, learn_from_pool, learner_from_records
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.trials.record import TrialDataset, TrialRecord, is_success, training_score


def _spec(skill: str):
    backend = load_backend("synthetic")
    try:
        return backend.skills()[skill]
    finally:
        backend.close()


def _records(n_valid: int = 8, n_invalid: int = 8) -> list[TrialRecord]:
    """``n_valid`` valid failures (score -0.5) and ``n_invalid`` invalid trials claiming a
    success (score 2.0), of skill moving2d, at seeded uniform inputs."""
    rng = np.random.default_rng(3)
    return [TrialRecord("moving2d", (float(rng.uniform(0, 1)),),
                        (float(rng.uniform(0, 4)), float(rng.uniform(-1, 1))),
                        -0.5 if i < n_valid else 2.0, i < n_valid, 100 + i, "synthetic",
                        index=i)
            for i in range(n_valid + n_invalid)]


def _run(*argv: str) -> tuple[int, str, list[str]]:
    stdout, stderr = io.StringIO(), io.StringIO()
    with redirect_stdout(stdout), redirect_stderr(stderr), pytest.raises(SystemExit) as done:
        main(list(argv))
    return int(done.value.code or 0), stdout.getvalue(), stderr.getvalue().strip().splitlines()


def test_training_score_never_labels_an_invalid_trial_a_success() -> None:
    invalid = TrialRecord("s", (), (0.0,), 3.0, False, 0, "b")
    assert training_score(invalid, -1.0) == -1.0 and not is_success(invalid)
    assert training_score(TrialRecord("s", (), (0.0,), -0.25, False, 0, "b"), -1.0) == -0.25
    assert training_score(TrialRecord("s", (), (0.0,), float("nan"), True, 0, "b"), -2.0) == -2.0
    assert training_score(TrialRecord("s", (), (0.0,), 0.5, True, 0, "b")) == 0.5


def test_pool_training_learns_invalid_successes_as_failures(tmp_path: Path) -> None:
    records = _records()
    path = tmp_path / "other_tool.jsonl"
    path.write_text("".join(r.to_json() + "\n" for r in records))
    before = path.read_bytes()
    # API
    result = learn_from_pool(_spec("moving2d"), records,
                             LearningConfig(strategy="gp", budget=16, seed=0))
    assert result.model.gp.y_np.max() <= 0.0
    # CLI twin: same labels, and the file is untouched
    code, _out, lines = _run("train", "moving2d", "--data", str(path), "--strategy", "gp",
                             "--budget", "16", "--out", str(tmp_path / "model"))
    assert code == 0, lines
    assert path.read_bytes() == before
    saved = json.loads((tmp_path / "model" / "model.json").read_text())
    assert saved["training"]["n_success"] == 0 and saved["training"]["n_valid"] == 8
    assert load_model(tmp_path / "model").model.gp.y_np.max() <= 0.0


def test_resumed_and_refitted_runs_learn_invalid_successes_as_failures(tmp_path: Path) -> None:
    out = tmp_path / "model"
    code, _out, lines = _run("train", "moving2d", "--strategy", "gp", "--budget", "6",
                             "--init", "6", "--out", str(out))
    assert code == 0, lines
    extra = [TrialRecord("moving2d", r.context, r.control, 2.0, False, 500 + i, "synthetic",
                         index=6 + i) for i, r in enumerate(_records(0, 4))]
    TrialDataset(out / "trials.jsonl").append(extra)
    code, _out, lines = _run("train", "moving2d", "--refit", "--out", str(out))
    assert code == 0, lines
    model = load_model(out).model
    assert model.gp.n == 10 and np.all(model.gp.y_np[6:] == -1.0)
    # the learner a resumed run (and ask/tell) rebuilds from the same file
    learner = learner_from_records(_spec("moving2d"), LearningConfig(strategy="gp"),
                                   TrialDataset(out / "trials.jsonl").read(),
                                   np.random.default_rng(0))
    assert learner.y[6:] == [-1.0] * 4


def test_held_out_data_counts_invalid_successes_as_failures(tmp_path: Path) -> None:
    records = _records(4, 4)
    heldout = heldout_from_records(records, _spec("moving2d"))
    assert np.all(heldout.scores[4:] == -1.0)
    path = tmp_path / "test.jsonl"
    path.write_text("".join(r.to_json() + "\n" for r in records))
    code, _out, lines = _run("train", "moving2d", "--strategy", "gp", "--budget", "6",
                             "--init", "6", "--out", str(tmp_path / "m"))
    assert code == 0, lines
    model = load_model(tmp_path / "m").model
    code, out, lines = _run("evaluate", str(tmp_path / "m"), "--data", str(path),
                            "--trials", "0", "--json")
    assert code == 0, lines
    assert json.loads(out)["f1"] == pytest.approx(heldout.f1(model))


def test_invalid_outcome_is_not_relabelled() -> None:
    spec = _spec("flick2d")
    context, control, outcome = (1.0, 0.0, 0.0), (0.0, 0.0, 0.5), (1.0, 0.0)
    record = TrialRecord("flick2d", context, control, 0.0, False, 1, "synthetic", index=0,
                         outcome=outcome)
    learner = learner_from_records(spec, LearningConfig(strategy="gp", hindsight=True),
                                   [record], np.random.default_rng(0))
    _x, y = learner.training_set()
    assert len(y) == 1 and y[0] <= 0.0  # no relabelled "reached its own end" success


def test_pool_reader_labels_invalid_successes_as_failures() -> None:
    from bench.paper.pools import Pool

    records = _records(3, 3)
    pool = Pool("synthetic", "moving2d", records[:2], records[2:])
    assert np.all(pool.heldout().scores <= 0.0)
    assert pool.stats()["test_positives"] == 0 and pool.stats()["positive_fraction"] == 0.0


@pytest.mark.parametrize("invalid_score", [0.5, float("nan"), float("inf"), True])
def test_skill_invalid_score_must_be_a_failure(invalid_score: float) -> None:
    with pytest.raises(ValueError, match="invalid_score must be a finite number <= 0"):
        SkillSpec("s", ParamSpace((), (), ()), ParamSpace(("a",), (0.0,), (1.0,)),
                  invalid_score=invalid_score)
