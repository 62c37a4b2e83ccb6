"""A plugin backend whose ``run_trial`` misbehaves once: the trial is recorded as invalid
with the reason, training goes on. Before the fix a score of 1e300 ended online training
with "math domain error" and a ``None`` result with an AttributeError."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))

from test_new_skill import ThrowBackend

from ltamp_cli.backends.protocol import TrialResult
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.trials.record import TrialDataset


class OnceWrong(ThrowBackend):
    """The throw backend, whose fifth trial returns ``answer`` instead of its result."""

    def __init__(self, answer: Any) -> None:
        super().__init__()
        self.answer = answer
        self.calls = 0

    def run_trial(self, skill: str, context: np.ndarray, control: np.ndarray,
                  seed: int) -> Any:
        self.calls += 1
        result = super().run_trial(skill, context, control, seed)
        return self.answer if self.calls == 5 else result


@pytest.mark.parametrize("answer, reason", [
    (TrialResult(1e300, True), "beyond"),
    (None, "not a TrialResult"),
    (TrialResult("lots", True), "no number"),  # type: ignore[arg-type]
    (TrialResult(0.5, "false"), "not True or False"),  # type: ignore[arg-type]
    (TrialResult("0.5", True), "no number"),  # type: ignore[arg-type]
])
def test_bad_trial_result_is_an_invalid_trial(tmp_path: Path, answer: Any,
                                              reason: str) -> None:
    dataset = TrialDataset(tmp_path / "trials.jsonl")
    result = learn_online(OnceWrong(answer), "throw",
                          LearningConfig(budget=12, init=4, seed=0), dataset)
    assert len(result.records) == 12
    fifth = dataset.read()[4]
    assert not fifth.valid and fifth.score == -1.0 and reason in fifth.info["reason"]
