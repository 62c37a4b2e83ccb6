"""Baseline learners with the :class:`~ltamp_cli.learning.model.SkillModel` interface.

* ``nn-c`` / ``nn-r`` — scikit-learn multi-layer perceptron classifier / regressor;
* ``rf-c`` / ``rf-r`` — scikit-learn random forest classifier / regressor;
* ``random`` — no model: predicts the sign of the mean training score everywhere and proposes
  a uniformly random valid control (the paper's *Random* baseline).

Classifiers learn the label ``score > 0`` and are confident where ``p(success)`` is high;
regressors learn the score and are confident where it is high (section 6.1 of the paper).
"""

from __future__ import annotations

import numpy as np
from sklearn.ensemble import RandomForestClassifier, RandomForestRegressor
from sklearn.neural_network import MLPClassifier, MLPRegressor

from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.learning.acquisition import first_valid
from ltamp_cli.learning.model import DEFAULT_CANDIDATES, PhysicalValidity, SkillModel

SKLEARN_KINDS = ("nn-c", "nn-r", "rf-c", "rf-r")


def _estimator(kind: str, seed: int) -> object:
    seed %= 2**32  # scikit-learn takes 32-bit seeds
    if kind == "nn-c":
        return MLPClassifier(hidden_layer_sizes=(64, 64), max_iter=2000, random_state=seed)
    if kind == "nn-r":
        return MLPRegressor(hidden_layer_sizes=(64, 64), max_iter=2000, random_state=seed)
    if kind == "rf-c":
        return RandomForestClassifier(n_estimators=100, random_state=seed)
    if kind == "rf-r":
        return RandomForestRegressor(n_estimators=100, random_state=seed)
    raise ValueError(f"unknown baseline {kind!r}: expected one of {', '.join(SKLEARN_KINDS)}")


class SklearnModel(SkillModel):
    """A scikit-learn classifier or regressor on normalised inputs."""

    def __init__(
        self, spec: SkillSpec, kind: str, estimator: object | None, constant: float
    ) -> None:
        super().__init__(spec)
        self.kind = kind
        self.estimator = estimator
        # Used while a classifier has seen one class only (sklearn cannot fit it then).
        self.constant = float(constant)

    @property
    def is_classifier(self) -> bool:
        return self.kind.endswith("-c")

    @staticmethod
    def fit(
        spec: SkillSpec, kind: str, x: np.ndarray, y: np.ndarray, seed: int = 0
    ) -> SklearnModel:
        """Fit on normalised ``x (n, d)`` and scores ``y (n,)``."""
        estimator = _estimator(kind, seed)
        labels = y > 0.0
        if kind.endswith("-c"):
            if labels.all() or not labels.any():
                return SklearnModel(spec, kind, None, 1.0 if labels.all() else 0.0)
            estimator.fit(x, labels)  # type: ignore[attr-defined]
        else:
            estimator.fit(x, y)  # type: ignore[attr-defined]
        return SklearnModel(spec, kind, estimator, float(labels.mean()))

    def _raw(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float).reshape(-1, self.dim)
        if self.estimator is None:
            return np.full(len(x), self.constant)
        if self.is_classifier:
            classes = list(self.estimator.classes_)  # type: ignore[attr-defined]
            return self.estimator.predict_proba(x)[:, classes.index(True)]  # type: ignore[attr-defined]
        return np.asarray(self.estimator.predict(x), dtype=float)  # type: ignore[attr-defined]

    def decision_normalized(self, x: np.ndarray) -> np.ndarray:
        raw = self._raw(x)
        return raw - 0.5 if self.is_classifier else raw

    def confidence_normalized(self, x: np.ndarray) -> np.ndarray:
        return self._raw(x)


class RandomModel(SkillModel):
    """The no-learning baseline: uniformly random controls, constant prediction."""

    kind = "random"

    def __init__(self, spec: SkillSpec, mean_score: float) -> None:
        super().__init__(spec)
        self.mean_score = float(mean_score)

    @staticmethod
    def fit(spec: SkillSpec, x: np.ndarray, y: np.ndarray) -> RandomModel:
        return RandomModel(spec, float(np.mean(y)) if len(y) else 0.0)

    def decision_normalized(self, x: np.ndarray) -> np.ndarray:
        return np.full(len(np.atleast_2d(x)), self.mean_score)

    def confidence_normalized(self, x: np.ndarray) -> np.ndarray:
        return np.zeros(len(np.atleast_2d(x)))

    def most_confident_control(
        self,
        context: np.ndarray,
        rng: np.random.Generator | None = None,
        is_valid: PhysicalValidity | None = None,
        n_candidates: int = DEFAULT_CANDIDATES,
    ) -> tuple[np.ndarray, float]:
        """A uniformly random valid control (first valid of ``n_candidates`` draws, tested
        lazily in blocks: a validity test can cost a millisecond per control)."""
        rng = rng if rng is not None else np.random.default_rng(0)
        controls = self.spec.control.sample_uniform(rng, n_candidates)
        if is_valid is not None:
            context = np.asarray(context, dtype=float)
            first = first_valid(np.arange(len(controls)), controls, 1,
                                lambda batch: is_valid(context, batch))
            if len(first):
                return controls[int(first[0])], 0.0
        return controls[0], 0.0
