"""Learned skill models: the common interface and the GP level-set model.

Every learner (GP, neural network, random forest, random) is a :class:`SkillModel`:

* ``decision_normalized(x)`` — ``(m,)``, positive ⇔ predicted success (score units for
  regressors and the GP, ``p − 0.5`` for classifiers);
* ``confidence_normalized(x)`` — ``(m,)``, what the most-confident control maximises
  (``μ/σ`` for the GP, ``p`` for classifiers, the predicted score for regressors).

``x`` is always ``(m, d)`` normalised to ``[-1, 1]`` in the order ``[control..., context...]``;
the physical-unit methods take ``contexts (m, dα)`` (or one ``(dα,)``) and ``controls (m, dθ)``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable

import numpy as np

from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.learning.acquisition import ValidityTest, confidence_ratio, maximize
from ltamp_cli.learning.confidence import relaxed_beta
from ltamp_cli.learning.gp import GaussianProcess, fit_gp
from ltamp_cli.learning.normalize import BoxNormalizer, join_inputs, joint_space, split_inputs

# physical validity test for one context: (context (dα,), controls (n, dθ)) -> bool (n,)
PhysicalValidity = Callable[[np.ndarray, np.ndarray], np.ndarray]

DEFAULT_CANDIDATES = 10_000


class SkillModel(ABC):
    """A learned model of a skill's score/success; see the module doc for the conventions."""

    kind: str = "model"

    def __init__(self, spec: SkillSpec) -> None:
        self.spec = spec
        self.normalizer = BoxNormalizer.for_space(joint_space(spec))

    @property
    def dim(self) -> int:
        return self.spec.control.dim + self.spec.context.dim

    # ---- coordinates -------------------------------------------------------------------------
    def to_unit(self, contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
        """Physical ``contexts``/``controls`` -> normalised GP inputs ``(m, d)``."""
        return self.normalizer.to_unit(join_inputs(self.spec, contexts, controls))

    def from_unit(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Normalised ``(m, d)`` -> physical ``(contexts (m, dα), controls (m, dθ))``."""
        return split_inputs(self.spec, self.normalizer.from_unit(x))

    def validity_test(self, is_valid: PhysicalValidity | None) -> ValidityTest | None:
        """Lift a physical per-context validity test to normalised batches (grouped by context)."""
        if is_valid is None:
            return None

        def test(x: np.ndarray) -> np.ndarray:
            contexts, controls = self.from_unit(np.atleast_2d(x))
            result = np.zeros(len(controls), dtype=bool)
            unique, inverse = np.unique(contexts, axis=0, return_inverse=True)
            for group, context in enumerate(unique):
                rows = np.flatnonzero(inverse.reshape(-1) == group)
                result[rows] = np.asarray(is_valid(context, controls[rows]), dtype=bool)
            return result

        return test

    def save(self, directory: str, **metadata: object) -> None:
        """Write the model directory (see :mod:`.model_dir`); ``metadata`` must be JSON-able."""
        from ltamp_cli.learning.model_dir import save_model

        save_model(self, directory, **metadata)

    # ---- predictions -------------------------------------------------------------------------
    @abstractmethod
    def decision_normalized(self, x: np.ndarray) -> np.ndarray:
        """``(m,)``: positive ⇔ predicted success."""

    @abstractmethod
    def confidence_normalized(self, x: np.ndarray) -> np.ndarray:
        """``(m,)``: larger = more confident of success."""

    def predict_labels(self, contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
        """Predicted success ``(m,)`` bool for physical inputs."""
        return self.decision_normalized(self.to_unit(contexts, controls)) > 0.0

    def most_confident_control(
        self,
        context: np.ndarray,
        rng: np.random.Generator | None = None,
        is_valid: PhysicalValidity | None = None,
        n_candidates: int = DEFAULT_CANDIDATES,
    ) -> tuple[np.ndarray, float]:
        """``(θ* (dθ,) physical, confidence at θ*)`` for one physical ``context (dα,)``.

        Scores ``n_candidates`` uniform controls, sorts them by confidence and returns the
        first valid one (the paper's recipe for the scikit-learn baselines). If no candidate is
        valid, the most confident invalid one is returned.
        """
        rng = rng if rng is not None else np.random.default_rng(0)
        x = self._candidates(context, rng, n_candidates)
        values = self.confidence_normalized(x)
        order = np.argsort(-values, kind="stable")
        test = self.validity_test(is_valid)
        chosen = order[0]
        if test is not None:
            for start in range(0, len(order), 256):
                block = order[start : start + 256]
                ok = test(x[block])
                if ok.any():
                    chosen = block[int(np.argmax(ok))]
                    break
        return self.from_unit(x[chosen])[1][0], float(values[chosen])

    def _candidates(self, context: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
        x = np.zeros((n, self.dim))
        x[:, : self.spec.control.dim] = rng.uniform(-1.0, 1.0, size=(n, self.spec.control.dim))
        x[:, self.spec.control.dim :] = self._context_unit(context)
        return x

    def _context_unit(self, context: np.ndarray) -> np.ndarray:
        dummy = np.zeros((1, self.spec.control.dim))
        return self.to_unit(np.asarray(context, dtype=float), dummy)[0, self.spec.control.dim :]


class LevelSetModel(SkillModel):
    """A GP on a skill's score: the learned constraint ``g(θ, α) > 0`` with its uncertainty.

    GP inputs are ``[control..., context...]`` normalised to ``[-1, 1]``; predictions are the
    latent posterior ``(mean, std)`` of the score in score units.
    """

    kind = "gp"

    def __init__(self, spec: SkillSpec, gp: GaussianProcess,
                 data_candidates: bool = False) -> None:
        super().__init__(spec)
        if gp.dim != self.dim:
            raise ValueError(f"GP has {gp.dim} inputs but skill {spec.name!r} has {self.dim}")
        self.gp = gp
        #: θ* also considers the controls of the GP's training points (besides uniform
        #: candidates): set by learners for skills whose trials are relabelled
        #: (:mod:`~ltamp_cli.learning.outcomes`), where a training control that reached a
        #: goal is the likeliest θ* for goals near it, yet a needle among uniform draws.
        self.data_candidates = data_candidates

    @staticmethod
    def fit(
        spec: SkillSpec,
        contexts: np.ndarray,
        controls: np.ndarray,
        scores: np.ndarray,
        kernel: str = "matern52",
        seed: int = 0,
        restarts: int = 2,
    ) -> LevelSetModel:
        """Fit a GP to physical ``contexts (n, dα)``, ``controls (n, dθ)`` and ``scores (n,)``."""
        x = BoxNormalizer.for_space(joint_space(spec)).to_unit(
            join_inputs(spec, contexts, controls)
        )
        from ltamp_cli.learning.active import gp_bounds  # active imports this module

        gp = fit_gp(x, scores, kernel, restarts=restarts, rng=np.random.default_rng(seed),
                    bounds=gp_bounds(spec))
        return LevelSetModel(spec, gp)

    @property
    def kernel(self) -> str:
        return self.gp.kernel

    @property
    def lengthscales(self) -> np.ndarray:
        """ARD lengthscales ``(d,)`` in normalised units (``mlp``: ``1/sqrt(weight variance)``)."""
        return self.gp.lengthscales

    def predict_normalized(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(mean (m,), std (m,))`` for normalised ``x (m, d)``; no autograd, chunked."""
        return self.gp.predict(x)

    def predict(self, contexts: np.ndarray, controls: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(mean (m,), std (m,))`` for physical contexts/controls."""
        return self.gp.predict(self.to_unit(contexts, controls))

    def decision_normalized(self, x: np.ndarray) -> np.ndarray:
        return self.gp.predict(x)[0]

    def confidence_normalized(self, x: np.ndarray) -> np.ndarray:
        mean, std = self.gp.predict(x)
        return mean / std

    def most_confident_control(
        self,
        context: np.ndarray,
        rng: np.random.Generator | None = None,
        is_valid: PhysicalValidity | None = None,
        n_candidates: int = DEFAULT_CANDIDATES,
        n_restarts: int = 3,
    ) -> tuple[np.ndarray, float]:
        """``θ* = argmax μ/σ`` over valid controls for ``context``: ``(θ* (dθ,), μ/σ at θ*)``.

        Random candidates (plus the training controls when ``data_candidates``), then
        L-BFGS-B from the best ``n_restarts`` valid ones. If no candidate is valid, falls back
        to the unrestricted maximum.
        """
        rng = rng if rng is not None else np.random.default_rng(0)
        fixed = np.zeros(self.dim)
        fixed[self.spec.control.dim :] = self._context_unit(context)
        free = np.arange(self.dim) < self.spec.control.dim
        kwargs = {
            "fixed": fixed,
            "free": free,
            "n_candidates": n_candidates,
            "n_restarts": n_restarts,
        }
        if self.data_candidates:
            kwargs["extra"] = np.unique(self.gp.x_np[:, : self.spec.control.dim], axis=0)
        best = maximize(
            self.gp, confidence_ratio, rng, is_valid=self.validity_test(is_valid), **kwargs
        )
        if best is None:
            best = maximize(self.gp, confidence_ratio, rng, **kwargs)
        assert best is not None
        return self.from_unit(best.x)[1][0], best.value

    def beta(
        self,
        context: np.ndarray,
        lam: float = 0.95,
        rng: np.random.Generator | None = None,
        is_valid: PhysicalValidity | None = None,
    ) -> float:
        """Relaxed threshold ``β = Φ⁻¹(λ Φ(μ/σ at θ*))`` for ``context`` (λ ∈ [0.95, 0.999])."""
        return relaxed_beta(self.most_confident_control(context, rng, is_valid)[1], lam)

    @staticmethod
    def load(directory: str) -> LevelSetModel:
        """Reload a saved GP model without retraining."""
        from ltamp_cli.learning.model_dir import load_model

        model = load_model(directory).model
        if not isinstance(model, LevelSetModel):
            raise TypeError(f"{directory} holds a {model.kind!r} model, not a GP")
        return model
