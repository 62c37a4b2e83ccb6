"""Round 3: skills with outcomes whose declared functions misbehave (Python API).

A trial's outcome is checked against its own score when it is recorded, but hindsight
relabelling calls the skill's score function (and ``achieved_goal``) at goals no trial was
run at. Before the fix a score function that raised or returned NaN there, or an
``achieved_goal`` that raised or returned the wrong shape, ended ``learn_online`` with that
exception, *after* the trial was appended: every resume re-read the trial, relabelled it
again and crashed again. Now the points that cannot be relabelled are left out (the trial
itself is learned from), with one warning naming the skill and the function.

Also: ``OutcomeSpec`` accepted NaN / infinite outcome bounds (every trial was then invalid
as "far outside its declared range"), a numpy integer goal index was refused as "must be
>= 0", and ``goals=(True,)`` was taken as index 1.
"""

from __future__ import annotations

import logging
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "learning"))

from test_outcomes import TOSS, TossBackend, toss_score

from ltamp_cli.backends.protocol import OutcomeSpec, ParamSpace
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.trials.record import TrialDataset


def fails_far(contexts: np.ndarray, controls: np.ndarray, outcomes: np.ndarray) -> np.ndarray:
    if (contexts[:, 0] > 5.0).any():
        raise RuntimeError("no score beyond 5 m")
    return toss_score(contexts, controls, outcomes)


def nan_far(contexts: np.ndarray, controls: np.ndarray, outcomes: np.ndarray) -> np.ndarray:
    scores = toss_score(contexts, controls, outcomes)
    scores[contexts[:, 0] > 5.0] = np.nan
    return scores


def divide_by_zero(outcomes: np.ndarray) -> np.ndarray:
    raise ZeroDivisionError("division by zero")


BROKEN = {
    "score raises at far goals": {"score": fails_far},
    "score NaN at far goals": {"score": nan_far},
    "achieved_goal raises": {"achieved_goal": divide_by_zero},
    "achieved_goal wrong shape": {"achieved_goal": lambda o: np.zeros((len(o), 3))},
    "achieved_goal NaN": {"achieved_goal": lambda o: o * np.nan},
}


def toss_with(**changes: Any) -> Any:
    assert TOSS.outcome is not None
    fields = {"space": TOSS.outcome.space, "score": TOSS.outcome.score,
              "goals": TOSS.outcome.goals, "achieved_goal": TOSS.outcome.achieved_goal}
    fields.update(changes)
    return replace(TOSS, outcome=OutcomeSpec(**fields))


@pytest.mark.parametrize("broken", sorted(BROKEN))
def test_misbehaving_outcome_function_does_not_end_training(
        tmp_path: Path, broken: str, caplog: pytest.LogCaptureFixture) -> None:
    spec = toss_with(**BROKEN[broken])
    config = LearningConfig(strategy="gp", budget=12, init=6, seed=0, hindsight_goals=3)
    dataset = TrialDataset(tmp_path / "trials.jsonl")
    with caplog.at_level(logging.WARNING, logger="ltamp"):
        result = learn_online(TossBackend(spec), "toss", config, dataset)
    assert len(result.records) == 12 and all(t.valid for t in result.records)
    x = result.model.gp.x_np  # type: ignore[attr-defined]
    assert x.shape[0] > 12  # the points that could be relabelled are kept
    assert np.isfinite(result.model.gp.y_np).all()  # type: ignore[attr-defined]
    warnings = [r.getMessage() for r in caplog.records if "toss" in r.getMessage()]
    assert len(warnings) == 1 and "\n" not in warnings[0], warnings
    # resuming re-reads the 12 trials and relabels them again: no crash, no new trial lost
    again = learn_online(TossBackend(spec), "toss", replace(config, budget=14), dataset)
    assert len(again.records) == 14
    assert len((tmp_path / "trials.jsonl").read_text().splitlines()) == 14


def test_working_functions_relabel_every_trial_without_warning(
        caplog: pytest.LogCaptureFixture) -> None:
    config = LearningConfig(strategy="gp", budget=12, init=6, seed=0, hindsight_goals=3)
    with caplog.at_level(logging.WARNING, logger="ltamp"):
        result = learn_online(TossBackend(), "toss", config)
    assert result.model.gp.x_np.shape[0] == 12 * (1 + 1 + 3)  # type: ignore[attr-defined]
    assert not [r for r in caplog.records if "toss" in r.getMessage()]


@pytest.mark.parametrize("low, high", [(float("nan"), 10.0), (0.0, float("inf")),
                                       (-1e308, 1e308)])
def test_outcome_bounds_must_be_finite(low: float, high: float) -> None:
    with pytest.raises(ValueError, match="landing"):
        OutcomeSpec(space=ParamSpace(("landing",), (low,), (high,), ("m",)),
                    score=toss_score, goals=(0,))


def test_numpy_integer_goal_index_is_a_goal_index() -> None:
    spec = toss_with(goals=(np.int64(0),))
    assert spec.outcome is not None and spec.outcome.goals == (0,)
    assert type(spec.outcome.goals[0]) is int


@pytest.mark.parametrize("goals", [(True,), (0.0,), ("0",)])
def test_non_integer_goal_index_is_refused(goals: tuple[Any, ...]) -> None:
    with pytest.raises(ValueError, match="goal"):
        toss_with(goals=goals)
