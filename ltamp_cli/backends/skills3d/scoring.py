"""The Kitchen3D score: a piecewise-linear function of a filled fraction."""

from __future__ import annotations

import numpy as np


def piecewise_linear_score(fraction: float | np.ndarray, tau: float) -> float | np.ndarray:
    """``g(x; τ) = -1 + x/τ`` on ``[0, τ]`` and ``(x - τ)/(1 - τ)`` on ``(τ, 1]``.

    ``x`` is clipped to ``[0, 1]`` first, so ``g(0) = -1``, ``g(τ) = 0``, ``g(1) = 1``;
    ``g > 0`` exactly when ``x > τ``. Accepts a scalar or an array (same shape out).
    """
    if not 0.0 < tau < 1.0:
        raise ValueError(f"tau must be in (0, 1), got {tau!r}")
    x = np.clip(np.asarray(fraction, dtype=float), 0.0, 1.0)
    score = np.where(x <= tau, -1.0 + x / tau, (x - tau) / (1.0 - tau))
    return float(score) if score.ndim == 0 else score
