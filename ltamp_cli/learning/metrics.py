"""Evaluation metrics: held-out F1 and the success rate of the most confident control.

* F1: positive ⇔ true score > 0; predicted positive ⇔ ``decision > 0`` (predicted score > 0
  for regressors and the GP, ``p > 0.5`` for classifiers).
* Success rate: for each sampled context, the model's most confident valid control is scored
  by a *true* score function (the analytic one of the synthetic backend, or live trials).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from ltamp_cli.backends.protocol import SkillBackend, SkillSpec, drawn_context
from ltamp_cli.learning.model import PhysicalValidity, SkillModel

# physical contexts (k, dα), controls (k, dθ) -> true scores (k,)
TrueScore = Callable[[np.ndarray, np.ndarray], np.ndarray]


def wilson_interval(successes: int, trials: int, confidence: float = 0.95
                    ) -> tuple[float, float]:
    """Wilson score interval ``(low, high)`` of the rate ``successes / trials``.

    ``confidence`` is two-sided (0.95: z = 1.96). With no trials the interval is the whole
    ``(0.0, 1.0)``: nothing is known about the rate.
    """
    if not 0 <= successes <= trials:
        raise ValueError(f"need 0 <= successes <= trials, got {successes} of {trials}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")
    if trials == 0:
        return 0.0, 1.0
    z = NormalDist().inv_cdf(0.5 + confidence / 2.0)
    rate = successes / trials
    shrink = 1.0 + z * z / trials
    centre = (rate + z * z / (2.0 * trials)) / shrink
    half = z * math.sqrt(rate * (1.0 - rate) / trials + z * z / (4.0 * trials * trials)) / shrink
    return max(0.0, centre - half), min(1.0, centre + half)


def f1_score(true_scores: np.ndarray, decisions: np.ndarray) -> float:
    """F1 of ``decisions > 0`` against ``true_scores > 0``; 1.0 when both have no positive."""
    truth = np.asarray(true_scores) > 0.0
    predicted = np.asarray(decisions) > 0.0
    tp = int(np.sum(truth & predicted))
    fp = int(np.sum(~truth & predicted))
    fn = int(np.sum(truth & ~predicted))
    if tp + fp + fn == 0:
        return 1.0
    return 2.0 * tp / (2.0 * tp + fp + fn)


@dataclass(frozen=True)
class HeldOutSet:
    """Physical test inputs and their true scores (``contexts (n, dα)``, ``controls (n, dθ)``)."""

    contexts: np.ndarray
    controls: np.ndarray
    scores: np.ndarray

    def f1(self, model: SkillModel) -> float:
        return f1_score(
            self.scores, model.decision_normalized(model.to_unit(self.contexts, self.controls))
        )


@dataclass(frozen=True)
class Evaluation:
    """One checkpoint: held-out F1, success rate, and which evaluation contexts succeeded
    (``successes[i]`` for ``contexts[i]``; paired comparisons between learners use them)."""

    n_trials: int
    f1: float | None
    success_rate: float | None
    successes: tuple[bool, ...] | None = None


class SkillEvaluator:
    """Computes F1 (if a held-out set is given) and the success rate (if a true score is)."""

    def __init__(
        self,
        spec: SkillSpec,
        heldout: HeldOutSet | None = None,
        true_score: TrueScore | None = None,
        contexts: np.ndarray | None = None,
        is_valid: PhysicalValidity | None = None,
        seed: int = 0,
        n_candidates: int = 10_000,
    ) -> None:
        self.spec = spec
        self.heldout = heldout
        self.true_score = true_score
        if contexts is not None:
            contexts = np.asarray(contexts, dtype=float)
            contexts = contexts.reshape(len(contexts), spec.context.dim)
        self.contexts = contexts
        self.is_valid = is_valid
        self.seed = seed
        self.n_candidates = n_candidates

    @staticmethod
    def synthetic(
        backend: SkillBackend,
        skill: str,
        n_test: int = 2000,
        n_contexts: int = 50,
        seed: int = 12345,
    ) -> SkillEvaluator:
        """Evaluator for a backend with a vectorised ``true_score`` (the synthetic backend).

        ``n_test`` held-out points for F1 (>= 1), ``n_contexts`` contexts whose θ* is scored
        (>= 0): the limits and words of ``ltamp evaluate --n-test/--trials``.
        """
        if n_contexts < 0 or n_test < 1:
            raise ValueError(f"--trials must be >= 0 and --n-test >= 1, got {n_contexts} and "
                             f"{n_test}")
        spec = backend.skills()[skill]
        rng = np.random.default_rng(seed)
        contexts = np.array([drawn_context(backend, skill, rng) for _ in range(n_test)]).reshape(
            n_test, -1
        )
        controls = spec.control.sample_uniform(rng, n_test)
        true_score = getattr(backend, "true_score", None)
        if true_score is None:
            raise ValueError(f"backend {backend.name!r} has no vectorised true_score")

        def score(c: np.ndarray, u: np.ndarray) -> np.ndarray:
            return np.asarray(true_score(skill, c, u), dtype=float)

        heldout = HeldOutSet(contexts, controls, score(contexts, controls))
        eval_contexts = np.array([drawn_context(backend, skill, rng) for _ in range(n_contexts)])
        return SkillEvaluator(
            spec, heldout, score, eval_contexts, lambda c, u: backend.is_valid(skill, c, u), seed
        )

    def success_rate(self, model: SkillModel) -> float | None:
        """Fraction of contexts whose most confident valid control truly succeeds."""
        successes = self.successes(model)
        return None if successes is None else float(np.mean(successes))

    def successes(self, model: SkillModel) -> tuple[bool, ...] | None:
        """Per evaluation context: does the most confident valid control truly succeed?"""
        if self.true_score is None or self.contexts is None or len(self.contexts) == 0:
            return None
        rng = np.random.default_rng(self.seed)
        controls = np.array(
            [
                model.most_confident_control(context, rng, self.is_valid, self.n_candidates)[0]
                for context in self.contexts
            ]
        ).reshape(len(self.contexts), self.spec.control.dim)
        return tuple(bool(s) for s in self.true_score(self.contexts, controls) > 0.0)

    def evaluate(self, model: SkillModel, n_trials: int, success: bool = True) -> Evaluation:
        f1 = None if self.heldout is None else self.heldout.f1(model)
        successes = self.successes(model) if success else None
        rate = None if successes is None else float(np.mean(successes))
        return Evaluation(n_trials, f1, rate, successes)
