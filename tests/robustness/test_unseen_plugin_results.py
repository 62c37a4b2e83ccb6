"""Round 4: a skill backend ltamp has never seen (12-D context, 1-D control, named like a
built-in skill), whose trials report things no built-in backend does.

Bugs this file caught (each failed before its fix):

* **An invalid trial that "succeeded"** (``TrialResult(0.3, valid=False)``) was recorded
  and learned with its score: a skill whose every trial was invalid trained a GP that put
  θ* at μ/σ ≈ 2.3 (confident success) while ``evaluate`` (which counts valid successes
  only) scored it 0/20. Now such a trial is invalid with the skill's invalid score and the
  reason (its info kept); invalid scores ≤ 0 are kept as given.
* **``ltamp evaluate`` ran the plugin's ``run_trial`` bare**: a trial that raised, returned
  ``None`` or a string score ended ``evaluate`` with a traceback (exit 1), where
  ``collect``/``train`` record such a trial as invalid. ``evaluate`` now runs trials as they
  do (a failure here; one warning line counting the trials that raised).
"""

from __future__ import annotations

import io
from contextlib import redirect_stderr
from typing import Any

import numpy as np
import pytest

from ltamp_cli.backends.protocol import ParamSpace, SkillSpec, TrialResult
from ltamp_cli.cli.evaluate import _live_outcomes
from ltamp_cli.learning.active import LearningConfig, learn_online

N_CONTEXT = 12


class Slosh:
    """Tilt a 12-parameter container (``pour``, like the built-in skill): success when the
    tilt lies within 0.4 of the mean parameter − 0.5. ``answer`` overrides the result."""

    name = "slosh"

    def __init__(self, answer: str = "normal") -> None:
        names = tuple(f"c{i}" for i in range(N_CONTEXT))
        self.spec = SkillSpec("pour", ParamSpace(names, (0.0,) * N_CONTEXT, (1.0,) * N_CONTEXT),
                              ParamSpace(("tilt",), (-1.0,), (1.0,)), deterministic=True)
        self.answer = answer

    def skills(self) -> dict[str, SkillSpec]:
        return {"pour": self.spec}

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        return self.spec.context.sample_uniform(rng, 1)[0]

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return np.ones(len(np.atleast_2d(controls)), dtype=bool)

    def run_trial(self, skill: str, context: np.ndarray, control: np.ndarray,
                  seed: int) -> Any:
        score = 0.4 - abs(float(control[0]) - (float(np.mean(context)) - 0.5))
        if self.answer == "invalid":  # never runnable, but reports the would-be score
            return TrialResult(score, False, {"spilled_ml": 3.0})
        if self.answer == "raise":
            raise RuntimeError("motor stalled")
        if self.answer == "none":
            return None
        if self.answer == "string":
            return TrialResult(str(score), True)  # type: ignore[arg-type]
        return TrialResult(np.float32(score), True)

    def close(self) -> None:
        pass


def test_an_invalid_trial_never_teaches_a_success(tmp_path: Any) -> None:
    from ltamp_cli.trials.record import TrialDataset

    dataset = TrialDataset(tmp_path / "trials.jsonl")
    result = learn_online(Slosh("invalid"), "pour", LearningConfig(budget=15, init=5, seed=0),
                          dataset)
    records = dataset.read()
    assert len(records) == 15
    assert all(not r.valid and r.score <= 0.0 for r in records)
    relabelled = [r for r in records if "reason" in r.info]
    assert relabelled  # 3 of the 15 at seed 0
    assert all(r.score == -1.0 and "> 0 (a success)" in r.info["reason"]
               and r.info["spilled_ml"] == 3.0 for r in relabelled)
    # the model predicts failure everywhere: μ/σ at θ* ≤ 0 for every context tried
    rng = np.random.default_rng(1)
    for _ in range(5):
        context = Slosh().sample_context("pour", rng)
        _control, confidence = result.model.most_confident_control(context, rng)
        assert confidence <= 0.0


class _Middle:
    """A stand-in model whose θ* is tilt 0."""

    def most_confident_control(self, context: np.ndarray, rng: np.random.Generator,
                               is_valid: object) -> tuple[np.ndarray, float]:
        return np.array([0.0]), 0.0


@pytest.mark.parametrize("answer, warns", [
    ("raise", True), ("none", False), ("string", False), ("invalid", False),
])
def test_evaluate_counts_a_broken_trial_as_a_failure(answer: str, warns: bool) -> None:
    err = io.StringIO()
    with redirect_stderr(err):
        star, baseline, contexts = _live_outcomes(Slosh(answer), "pour", _Middle(), 6, 0)
    assert star == [0] * 6 and baseline == [0] * 6 and len(contexts) == 6
    lines = [line for line in err.getvalue().splitlines() if line]
    if warns:
        assert lines == ["ltamp: warning: 12 trial(s) raised (counted as failures), first: "
                         "trial raised RuntimeError: motor stalled"]
    else:
        assert lines == []
    # the same skill answering normally succeeds at θ* = 0 for central contexts
    star, _baseline, contexts = _live_outcomes(Slosh(), "pour", _Middle(), 6, 0)
    assert star == [int(abs(np.mean(c) - 0.5) < 0.4) for c in contexts]


def test_tell_refuses_an_invalid_success_in_the_api_and_the_cli(tmp_path: Any) -> None:
    """``tell --invalid --score 0.5`` recorded a success that could not be run (learned as
    one); now refused before anything is written, with the same line from API and CLI."""
    from contextlib import redirect_stdout

    from ltamp_cli.backends import load_backend
    from ltamp_cli.cli.app import main
    from ltamp_cli.errors import InputError
    from ltamp_cli.learning.ask_tell import ask, tell

    backend = load_backend("synthetic")
    try:
        ask(backend, "moving2d", LearningConfig(seed=0), tmp_path / "m")
    finally:
        backend.close()
    with pytest.raises(InputError) as caught:
        tell(tmp_path / "m", 0.5, valid=False)
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["tell", str(tmp_path / "m"), "--score", "0.5", "--invalid"])
    assert done.value.code == 2
    assert err.getvalue().splitlines() == [f"ltamp: error: {caught.value}"]
    assert "--invalid" in str(caught.value)
    assert not (tmp_path / "m" / "trials.jsonl").exists()
    record = tell(tmp_path / "m", -1.0, valid=False)  # an honest invalid trial is recorded
    assert not record.valid and record.score == -1.0


def test_import_refuses_an_invalid_success(tmp_path: Any) -> None:
    """A recorded row with ``valid`` false and a score > 0 was imported as is (and learned
    as a success by ``train --data``); now one positioned line, nothing appended."""
    from contextlib import redirect_stdout

    from ltamp_cli.cli.app import main

    source = tmp_path / "recorded.csv"
    source.write_text("x,y,phase,score,valid\n0.3,0.2,0.1,-0.5,true\n0.1,0.2,0.1,0.5,false\n")
    out = tmp_path / "trials.jsonl"
    stdout, err = io.StringIO(), io.StringIO()
    with redirect_stdout(stdout), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["import", str(source), "--skill", "moving2d", "--out", str(out)])
    assert done.value.code == 2
    assert err.getvalue().splitlines() == [
        f"ltamp: error: {source}:3:1: field 'score': 0.5 > 0 is a success, but 'valid' says "
        "the trial could not be run: give its score <= 0 (e.g. -1)"]
    assert not out.exists()
