"""Proposal distributions on a box, with exact densities for importance weights.

Both proposals live in the normalised control box ``B = [lows, highs]`` (``[-1, 1]^dθ`` for
the samplers). :class:`UniformBox` has density ``1/Vol(B)``; :class:`TruncatedGaussianMixture`
is a mixture of axis-aligned Gaussians each *truncated* to ``B`` (sampled by a per-dimension
inverse CDF, so every draw lies in the box and the density is exact, not clipped).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import log_ndtr, ndtri_exp

_LOG_SQRT_2PI = 0.5 * np.log(2.0 * np.pi)


@dataclass(frozen=True)
class UniformBox:
    """Uniform distribution on the box ``[lows, highs]`` (arrays ``(d,)``)."""

    lows: np.ndarray
    highs: np.ndarray

    @staticmethod
    def unit(dim: int) -> UniformBox:
        """The normalised box ``[-1, 1]^dim``."""
        return UniformBox(-np.ones(dim), np.ones(dim))

    @property
    def dim(self) -> int:
        return len(self.lows)

    @property
    def volume(self) -> float:
        return float(np.prod(self.highs - self.lows))

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``(n, d)`` uniform points."""
        return rng.uniform(self.lows, self.highs, size=(n, self.dim))

    def log_density(self, x: np.ndarray) -> np.ndarray:
        """``(n,)``: ``-log Vol(B)`` inside the box, ``-inf`` outside."""
        x = np.asarray(x, dtype=float).reshape(-1, self.dim)
        inside = np.all((x >= self.lows) & (x <= self.highs), axis=1)
        return np.where(inside, -np.log(self.volume), -np.inf)


def _truncated_standard_normal(
    a: np.ndarray, b: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Draws from N(0, 1) truncated to ``[a, b]`` (same shapes), by inverse CDF in log space.

    Intervals in the upper tail are mirrored to the lower tail and ``Φ`` is inverted from
    ``log Φ``, so even intervals many standard deviations away are sampled exactly.
    """
    flip = a > 0.0
    lo = np.where(flip, -b, a)
    hi = np.where(flip, -a, b)
    log_lo, log_hi = log_ndtr(lo), log_ndtr(hi)
    u = rng.uniform(size=a.shape)
    # log(Φ(lo) + u (Φ(hi) − Φ(lo))) = log Φ(hi) + log(u + (1 − u) Φ(lo)/Φ(hi))
    log_p = log_hi + np.log(u + (1.0 - u) * np.exp(log_lo - log_hi))
    z = np.clip(ndtri_exp(np.minimum(log_p, 0.0)), lo, hi)  # clip: rounding only
    return np.where(flip, -z, z)


def _log_mass(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``log(Φ(b) − Φ(a))`` for ``a < b``, stable in both tails."""
    flip = a > 0.0
    lo = np.where(flip, -b, a)
    hi = np.where(flip, -a, b)
    log_hi, log_lo = log_ndtr(hi), log_ndtr(lo)
    return log_hi + np.log1p(-np.exp(np.minimum(log_lo - log_hi, 0.0)) + 1e-300)


@dataclass(frozen=True)
class TruncatedGaussianMixture:
    """Mixture of ``k`` Gaussians ``N(means[i], diag(scales²))`` truncated to ``[lows, highs]``.

    ``means (k, d)``, ``scales (d,)`` (shared, the paper's circular variance per dimension)
    or ``(k, d)``, ``weights (k,)`` (normalised here), ``lows``/``highs (d,)``.
    """

    means: np.ndarray
    scales: np.ndarray
    weights: np.ndarray
    lows: np.ndarray
    highs: np.ndarray

    def __post_init__(self) -> None:
        means = np.atleast_2d(np.asarray(self.means, dtype=float))
        scales = np.broadcast_to(np.asarray(self.scales, dtype=float), means.shape)
        weights = np.asarray(self.weights, dtype=float).reshape(len(means))
        if np.any(scales <= 0.0) or not np.all(np.isfinite(scales)):
            raise ValueError("TGMM scales must be positive and finite")
        if np.any(weights < 0.0) or weights.sum() <= 0.0:
            raise ValueError("TGMM weights must be non-negative with a positive sum")
        object.__setattr__(self, "means", means)
        object.__setattr__(self, "scales", scales)
        object.__setattr__(self, "weights", weights / weights.sum())
        object.__setattr__(self, "lows", np.asarray(self.lows, dtype=float))
        object.__setattr__(self, "highs", np.asarray(self.highs, dtype=float))

    @property
    def dim(self) -> int:
        return self.means.shape[1]

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``(n, d)`` draws, every one inside the box."""
        component = rng.choice(len(self.means), size=n, p=self.weights)
        mean = self.means[component]
        scale = self.scales[component]
        a = (self.lows - mean) / scale
        b = (self.highs - mean) / scale
        return mean + scale * _truncated_standard_normal(a, b, rng)

    def log_density(self, x: np.ndarray) -> np.ndarray:
        """``(n,)`` log density at ``x (n, d)`` (``-inf`` outside the box)."""
        x = np.asarray(x, dtype=float).reshape(-1, self.dim)
        a = (self.lows - self.means) / self.scales  # (k, d)
        b = (self.highs - self.means) / self.scales
        # Per component: −Σ_d [log s + log √2π + log Z] + log w  (Z = truncated mass).
        constant = np.log(self.weights + 1e-300) - (
            np.log(self.scales) + _LOG_SQRT_2PI + _log_mass(a, b)
        ).sum(axis=1)
        log_terms = np.empty((len(x), len(self.means)))
        for start in range(0, len(x), 2048):
            z = (x[start : start + 2048, None, :] - self.means[None]) / self.scales[None]
            log_terms[start : start + 2048] = -0.5 * (z * z).sum(axis=2) + constant
        peak = log_terms.max(axis=1)
        out = peak + np.log(np.exp(log_terms - peak[:, None]).sum(axis=1))
        inside = np.all((x >= self.lows) & (x <= self.highs), axis=1)
        return np.where(inside, out, -np.inf)
