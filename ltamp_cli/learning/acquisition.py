"""The straddle acquisition and a box maximiser for GP-derived objectives.

All points are *normalised* GP inputs ``(d,)`` / ``(m, d)`` in ``[-1, 1]`` (order
``[control..., context...]``). Some coordinates can be held fixed (e.g. the context in
``lse2`` or when choosing a control for a given context): the maximiser searches only the
``free`` ones. It follows the earlier code's recipe: score many uniform random candidates, then
run L-BFGS-B (autograd gradients) inside the box from the best few.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
from scipy.optimize import minimize

from ltamp_cli.learning.gp import DTYPE, GaussianProcess

STRADDLE_WIDTH = 1.96

# (mean (m,), std (m,)) -> objective (m,); works on numpy arrays and torch tensors alike.
Objective = Callable[[object, object], object]
# normalised points (m, d) -> bool (m,): the hard validity test in normalised coordinates.
ValidityTest = Callable[[np.ndarray], np.ndarray]


def straddle(mean: np.ndarray, std: np.ndarray) -> np.ndarray:
    """ψ = −|μ| + 1.96σ (Bryan et al. 2006): high near the zero level set or where unsure."""
    return -abs(mean) + STRADDLE_WIDTH * std


def confidence_ratio(mean: np.ndarray, std: np.ndarray) -> np.ndarray:
    """φ = μ/σ: how many standard deviations the prediction lies above the level set."""
    return mean / std


@dataclass(frozen=True)
class Maximum:
    """Best point ``x (d,)`` (normalised) and its objective ``value``."""

    x: np.ndarray
    value: float


def evaluate(gp: GaussianProcess, objective: Objective, x: np.ndarray) -> np.ndarray:
    """Objective on a batch ``(m, d)`` in scaled-score units, chunked and without autograd."""
    with torch.no_grad():
        mean, variance = gp.posterior_blocks(torch.as_tensor(x, dtype=DTYPE))
        return objective(mean, variance.sqrt_()).numpy().astype(float, copy=False)


def first_valid(
    order: np.ndarray,
    points: np.ndarray,
    count: int,
    is_valid: ValidityTest | None,
    block: int = 64,
) -> np.ndarray:
    """The first ``count`` indices of ``order`` whose points pass ``is_valid`` (checked lazily)."""
    if is_valid is None:
        return order[:count]
    chosen: list[int] = []
    for start in range(0, len(order), block):
        indices = order[start : start + block]
        ok = np.asarray(is_valid(points[indices]), dtype=bool)
        chosen.extend(indices[ok][: count - len(chosen)].tolist())
        if len(chosen) >= count:
            break
    return np.asarray(chosen, dtype=int)


def maximize(
    gp: GaussianProcess,
    objective: Objective,
    rng: np.random.Generator,
    fixed: np.ndarray | None = None,
    free: np.ndarray | None = None,
    n_candidates: int = 10_000,
    n_restarts: int = 3,
    is_valid: ValidityTest | None = None,
    max_iter: int = 25,
    extra: np.ndarray | None = None,
) -> Maximum | None:
    """Maximise ``objective(μ, σ)`` over the free coordinates of ``[-1, 1]^d``.

    ``fixed (d,)`` gives the values of the coordinates not in ``free`` (a bool mask ``(d,)``;
    default: all free). ``extra (k, n_free)`` adds candidates (their free coordinates) to
    the uniform ones. Returns ``None`` when no candidate passes ``is_valid``.
    """
    d = gp.dim
    free = np.ones(d, dtype=bool) if free is None else np.asarray(free, dtype=bool)
    base = np.zeros(d) if fixed is None else np.asarray(fixed, dtype=float).reshape(d)
    candidates = np.repeat(base[None, :], n_candidates, axis=0)
    candidates[:, free] = rng.uniform(-1.0, 1.0, size=(n_candidates, int(free.sum())))
    if extra is not None and len(extra):
        more = np.repeat(base[None, :], len(extra), axis=0)
        more[:, free] = np.asarray(extra, dtype=float).reshape(len(extra), int(free.sum()))
        candidates = np.vstack([candidates, more])
    values = evaluate(gp, objective, candidates)
    order = np.argsort(-values, kind="stable")
    starts = first_valid(order, candidates, n_restarts, is_valid)
    if len(starts) == 0:
        return None
    best = Maximum(candidates[starts[0]].copy(), float(values[starts[0]]))
    if not free.any():
        return best
    # All starts are refined in one L-BFGS-B run: the objective is a sum of independent
    # per-start terms, so one batched posterior call per step serves every start.
    n_free = int(free.sum())
    base_t = torch.as_tensor(base, dtype=DTYPE)
    free_t = torch.as_tensor(np.flatnonzero(free))

    def batch(z_t: torch.Tensor) -> torch.Tensor:
        points = base_t.repeat(len(starts), 1)
        points[:, free_t] = z_t.reshape(len(starts), n_free)
        mean, variance = gp.posterior_torch(points)
        return objective(mean, variance.sqrt())

    def negative(z: np.ndarray) -> tuple[float, np.ndarray]:
        z_t = torch.tensor(z, dtype=DTYPE, requires_grad=True)
        value = -batch(z_t).sum()
        (gradient,) = torch.autograd.grad(value, z_t)
        return float(value.detach()), gradient.numpy().copy()

    result = minimize(
        negative,
        candidates[starts][:, free].reshape(-1),
        jac=True,
        method="L-BFGS-B",
        bounds=[(-1.0, 1.0)] * (len(starts) * n_free),
        options={"maxiter": max_iter, "maxfun": 2 * max_iter},
    )
    refined = np.repeat(base[None, :], len(starts), axis=0)
    refined[:, free] = np.clip(result.x, -1.0, 1.0).reshape(len(starts), n_free)
    with torch.no_grad():
        refined_values = batch(torch.as_tensor(refined[:, free].reshape(-1), dtype=DTYPE)).numpy()
    for row in np.argsort(-refined_values, kind="stable"):
        value = float(refined_values[row])
        if not np.isfinite(value) or value <= best.value:
            break
        if is_valid is None or bool(np.asarray(is_valid(refined[row][None, :]))[0]):
            return Maximum(refined[row], value)
    return best
