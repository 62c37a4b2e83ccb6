"""The diversity kernel and its task-level learning (Algorithm 5 of the paper).

Diversity is measured with a squared-exponential kernel on normalised controls,
``ξ(θ, γ; l) = exp(−Σ_d (l_d (θ_d − γ_d))²)`` with *inverse* lengthscales ``l (dθ,)``, and an
observation noise ``ζ`` (0.1). The conditional variance
``η_S(θ) = ξ(θ, θ) − ξ_S(θ)ᵀ (Ξ_S + ζ² I)⁻¹ ξ_S(θ)`` is how new ``θ`` is given the samples ``S``.

When the planner reports that a sample ``θ`` drawn after ``S`` was unusable, the feature that
made ``θ`` look most different from ``S`` — ``argmax_d τ(d)``, where ``τ(d)`` is ``η_S(θ)``
computed with the kernel restricted to feature ``d`` but the full ``(Ξ_S + ζ² I)⁻¹`` — has its
inverse lengthscale shrunk to ``(1 − ε) l_d``: differences along it stop counting as diversity.
Shrinking stops at :data:`MIN_INVERSE_LENGTHSCALE`, where a feature's whole normalised range
changes ``ξ`` by under 0.1 %: the paper's rule has no floor, and a planner that keeps
rejecting samples (hundreds of reports in one hard problem) otherwise drives every ``l_d``
to underflow and persists that kernel for later tasks. Features already at the floor are
passed over for the next most important one.

The learned kernel persists per skill as JSON at a path the caller chooses
(:func:`load_kernel` / :func:`save_kernel`); learned streams default to the user cache.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.linalg import cho_solve, cholesky

from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.errors import InputError, location_in
from ltamp_cli.jsondata import read_json_data

EPSILON = 0.3
MIN_INVERSE_LENGTHSCALE = 0.03
ZETA = 0.1
FORMAT = "ltamp-diversity-kernel"
VERSION = 1


@dataclass
class DiversityKernel:
    """SE kernel with inverse lengthscales ``l (dθ,)`` (normalised units) and its learning state.

    ``updates`` counts learning steps; samplers use it to notice that ``l`` changed.
    """

    inverse_lengthscales: np.ndarray
    epsilon: float = EPSILON
    zeta: float = ZETA
    updates: int = 0

    def __post_init__(self) -> None:
        self.inverse_lengthscales = np.asarray(self.inverse_lengthscales, dtype=float).copy()
        if np.any(self.inverse_lengthscales < 0) or not np.all(
            np.isfinite(self.inverse_lengthscales)
        ):
            raise ValueError("inverse lengthscales must be finite and >= 0")
        if not 0.0 < self.epsilon < 1.0:
            raise ValueError(f"epsilon must be in (0, 1), got {self.epsilon}")
        if self.zeta <= 0.0:
            raise ValueError(f"zeta must be > 0, got {self.zeta}")

    @staticmethod
    def unit(dim: int, epsilon: float = EPSILON, zeta: float = ZETA) -> DiversityKernel:
        """The fixed kernel of the paper's diversity metric: ``l = [1, …, 1]``."""
        return DiversityKernel(np.ones(dim), epsilon, zeta)

    @property
    def dim(self) -> int:
        return len(self.inverse_lengthscales)

    def gram(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``ξ(a_i, b_j)`` for ``a (n, d)``, ``b (k, d)`` -> ``(n, k)``."""
        za = np.asarray(a, dtype=float).reshape(-1, self.dim) * self.inverse_lengthscales
        zb = np.asarray(b, dtype=float).reshape(-1, self.dim) * self.inverse_lengthscales
        sq = (za * za).sum(1)[:, None] - 2.0 * za @ zb.T + (zb * zb).sum(1)[None, :]
        return np.exp(-np.maximum(sq, 0.0))

    def noisy_factor(self, selected: np.ndarray) -> np.ndarray:
        """Lower Cholesky factor of ``Ξ_S + ζ² I`` for ``selected (k, d)``."""
        gram = self.gram(selected, selected) + self.zeta**2 * np.eye(len(selected))
        return cholesky(gram, lower=True)

    def conditional_variance(self, candidates: np.ndarray, selected: np.ndarray) -> np.ndarray:
        """``η_S (n,)`` for ``candidates (n, d)`` given ``selected (k, d)`` (k may be 0)."""
        candidates = np.asarray(candidates, dtype=float).reshape(-1, self.dim)
        selected = np.asarray(selected, dtype=float).reshape(-1, self.dim)
        if len(selected) == 0:
            return np.ones(len(candidates))
        cross = self.gram(selected, candidates)  # (k, n)
        solved = cho_solve((self.noisy_factor(selected), True), cross)
        return 1.0 - (cross * solved).sum(0)

    def feature_importance(self, theta: np.ndarray, selected: np.ndarray) -> np.ndarray:
        """``τ_S^θ (d,)``: per-feature conditional variance of ``theta`` with the full inverse."""
        theta = np.asarray(theta, dtype=float).reshape(self.dim)
        selected = np.asarray(selected, dtype=float).reshape(-1, self.dim)
        if len(selected) == 0:
            return np.ones(self.dim)
        factor = self.noisy_factor(selected)
        per_feature = np.exp(-((self.inverse_lengthscales * (selected - theta)) ** 2))  # (k, d)
        solved = cho_solve((factor, True), per_feature)
        return 1.0 - (per_feature * solved).sum(0)

    def update(self, theta: np.ndarray, selected: np.ndarray) -> int | None:
        """Algorithm 5's step for an unusable ``theta`` drawn after ``selected``.

        Returns the feature whose inverse lengthscale was shrunk (``None`` when ``S`` is empty
        or every feature is already at :data:`MIN_INVERSE_LENGTHSCALE`).
        """
        selected = np.asarray(selected, dtype=float).reshape(-1, self.dim)
        shrinkable = self.inverse_lengthscales > MIN_INVERSE_LENGTHSCALE
        if len(selected) == 0 or not shrinkable.any():
            return None
        importance = np.where(shrinkable, self.feature_importance(theta, selected), -np.inf)
        feature = int(np.argmax(importance))
        self.inverse_lengthscales[feature] = max(
            self.inverse_lengthscales[feature] * (1.0 - self.epsilon), MIN_INVERSE_LENGTHSCALE
        )
        self.updates += 1
        return feature

    def to_json(self) -> dict[str, Any]:
        return {
            "inverse_lengthscales": self.inverse_lengthscales.tolist(),
            "epsilon": self.epsilon,
            "zeta": self.zeta,
            "updates": self.updates,
        }


def diversity(samples: np.ndarray, kernel: DiversityKernel | None = None) -> float:
    """``D(S) = log det(Ξ_S / ζ² + I)`` for ``samples (k, d)`` (unit kernel by default)."""
    samples = np.asarray(samples, dtype=float)
    if samples.ndim != 2 or len(samples) == 0:
        return 0.0
    kernel = kernel or DiversityKernel.unit(samples.shape[1])
    matrix = kernel.gram(samples, samples) / kernel.zeta**2 + np.eye(len(samples))
    return float(np.linalg.slogdet(matrix)[1])


def load_kernel(path: str | Path, spec: SkillSpec) -> DiversityKernel:
    """The learned kernel of ``spec``'s controls at ``path``; a fresh unit kernel if absent."""
    path = Path(path)
    if not path.exists():
        return DiversityKernel.unit(spec.control.dim)
    data = read_json_data(path)
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise InputError(f"not a diversity kernel file (expected format {FORMAT!r})",
                         location_in(path))
    if data.get("version") != VERSION:
        raise InputError(f"unsupported diversity kernel version {data.get('version')!r}",
                         location_in(path))
    if data.get("skill") != spec.name or list(data.get("controls", [])) != list(
            spec.control.names):
        raise InputError(
            f"kernel is for skill {data.get('skill')!r} with controls {data.get('controls')}, "
            f"not {spec.name!r} with {list(spec.control.names)}",
            location_in(path),
        )
    try:
        return DiversityKernel(
            np.asarray(data["inverse_lengthscales"], dtype=float).reshape(spec.control.dim),
            float(data.get("epsilon", EPSILON)),
            float(data.get("zeta", ZETA)),
            int(data.get("updates", 0)),
        )
    except (KeyError, TypeError, ValueError) as error:
        raise InputError(f"bad diversity kernel ({error})", location_in(path)) from None


def save_kernel(kernel: DiversityKernel, path: str | Path, spec: SkillSpec) -> Path:
    """Write ``kernel`` for ``spec`` to ``path`` atomically (parent folders created)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    record = {
        "format": FORMAT,
        "version": VERSION,
        "skill": spec.name,
        "controls": list(spec.control.names),
        **kernel.to_json(),
    }
    handle, temporary = tempfile.mkstemp(prefix=path.name, suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(handle, "w") as stream:
            stream.write(json.dumps(record, indent=2) + "\n")
        os.replace(temporary, path)
    finally:  # a failed write (full disk) leaves no temporary behind
        Path(temporary).unlink(missing_ok=True)
    return path
