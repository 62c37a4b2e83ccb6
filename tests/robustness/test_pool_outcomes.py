"""Round 3: outcomes read from a trial file (``train --data``, ``tell``) were only checked
for their length. A recorded outcome far outside its declared range, or one whose declared
score function disagrees with the record's score (``score -2.5`` with an outcome that
scores ``-999998.5``), was learned from: the record's score *and* relabelled points from
the contradicting outcome went into one GP. A live trial's outcome is refused for both
(``checked_outcome``); a recorded one now is too, in one line naming the record."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "learning"))

from test_outcomes import TOSS

from ltamp_cli.learning.active import LearningConfig, learn_from_pool
from ltamp_cli.trials.record import TrialRecord

CONFIG = LearningConfig(strategy="gp", budget=6, init=6, seed=0, hindsight_goals=1)


def pool_with(outcome: tuple[float, ...], score: float) -> list[TrialRecord]:
    pool = [TrialRecord("toss", (1.0,), (v,), 0.5 - abs(v - 1.0), True, i, "toss-test",
                        index=i, outcome=(v,))
            for i, v in enumerate([0.2, 1.1, 2.5, 4.0, 7.0, 9.5])]
    pool[3] = TrialRecord("toss", (1.0,), (4.0,), score, True, 3, "toss-test", index=3,
                          outcome=outcome)
    return pool


@pytest.mark.parametrize("outcome, score, message", [
    ((1e6,), -2.5, "far outside"),
    ((4.0,), 0.4, "score function gives -2.5"),
    ((9.0,), -2.5, "score function gives -7.5"),
])
def test_recorded_outcome_must_fit_the_skill(outcome: tuple[float, ...], score: float,
                                             message: str) -> None:
    with pytest.raises(ValueError, match=message) as error:
        learn_from_pool(TOSS, pool_with(outcome, score), CONFIG)
    assert "index 3" in str(error.value) and "\n" not in str(error.value)


def test_consistent_outcomes_are_learned() -> None:
    result = learn_from_pool(TOSS, pool_with((4.0,), -2.5), CONFIG)
    assert result.model.gp.x_np.shape[0] == 6 * 3  # type: ignore[attr-defined]


def test_invalid_records_outcomes_are_not_checked() -> None:
    pool = pool_with((4.0,), -2.5)
    pool[3] = TrialRecord("toss", (1.0,), (4.0,), -1.0, False, 3, "toss-test", index=3,
                          outcome=None)
    learn_from_pool(TOSS, pool, CONFIG)
