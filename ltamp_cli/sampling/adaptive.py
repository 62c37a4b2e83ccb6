"""Adaptive sampling from ``Â_α`` (Algorithms 2–3 of the paper).

:func:`sample_buffer` grows a weighted pool of members: each round draws ``n`` proposals from
a truncated Gaussian mixture (TGMM) centred on the members found so far (mixture weights =
their importance weights) and ``n`` uniform proposals, keeps the members, and weights each by
``1/q(θ)`` for the proposal density ``q`` that drew it (``1/p_TGMM`` or ``Vol(B)``), so that the
weighted pool approximates the uniform distribution on ``Â_α``. The TGMM scale starts at the
GP's control lengthscales and is doubled when more than ``n/2`` TGMM proposals are accepted,
halved when fewer than ``n/10`` are. Once the pool holds more than ``m`` members it is returned.

:class:`AdaptiveSampler` keeps a buffer of at least ``m/2`` samples, each buffer refill being
``m`` members drawn from the pool by importance weight *without replacement*; a new pool is
only built once fewer than ``m`` members remain in the current one (drawing a pool's members in
successive groups without replacement is the same as drawing them all at once).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from ltamp_cli.sampling.base import SetSampler
from ltamp_cli.sampling.proposals import TruncatedGaussianMixture, UniformBox
from ltamp_cli.sampling.superlevel import DEFAULT_PROPOSALS, SuperLevelSet

DEFAULT_BUFFER = 50
MAX_ROUNDS = 20
# TGMM scales (normalised units) stay in a range where the box is neither a point nor flat.
SCALE_RANGE = (1e-4, 1e2)


@dataclass
class WeightedPool:
    """Members ``points (k, dθ)`` (normalised) and their importance ``weights (k,)``."""

    points: np.ndarray
    weights: np.ndarray

    def __len__(self) -> int:
        return len(self.points)

    def draw(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """Remove and return ``min(count, len)`` members, by weight, without replacement."""
        count = min(count, len(self))
        if count == 0:
            return self.points[:0]
        p = self.weights / self.weights.sum()
        if count == len(self):
            chosen = rng.permutation(len(self)) if np.all(p > 0) else np.argsort(-p)
        else:
            positive = int(np.count_nonzero(p))
            if positive < count:  # a few zero weights: take every positive one first
                chosen = np.argsort(-p, kind="stable")[:count]
            else:
                chosen = rng.choice(len(self), size=count, replace=False, p=p)
        keep = np.ones(len(self), dtype=bool)
        keep[chosen] = False
        taken = self.points[chosen]
        self.points, self.weights = self.points[keep], self.weights[keep]
        return taken


def sample_buffer(
    sampler: SetSampler,
    init_means: np.ndarray,
    init_members: np.ndarray,
    scale: np.ndarray,
    n: int = DEFAULT_PROPOSALS,
    m: int = DEFAULT_BUFFER,
    max_rounds: int = MAX_ROUNDS,
) -> tuple[WeightedPool, np.ndarray]:
    """Algorithm 3 up to its final resampling: ``(pool with > m members if found, new scale)``.

    ``init_means (k, dθ)`` centre the first TGMM; ``init_members (j, dθ)`` (members already
    known, e.g. ``θ*``) start the pool with weight ``Vol(B)``. Uses the set's seed members as
    the first round's uniform proposals when they are still available.
    """
    superlevel, rng = sampler.superlevel, sampler.rng
    box = UniformBox.unit(superlevel.dim)
    volume = superlevel.volume
    points = [np.asarray(init_members, dtype=float).reshape(-1, superlevel.dim)]
    weights = [np.full(len(points[0]), volume)]
    means = np.asarray(init_means, dtype=float).reshape(-1, superlevel.dim)
    mixture = np.ones(len(means))
    scale = np.asarray(scale, dtype=float).copy()
    for _ in range(max_rounds):
        tgmm = TruncatedGaussianMixture(means, scale, mixture, box.lows, box.highs)
        accepted = sampler._members(tgmm.sample(rng, n))
        points.append(accepted)
        weights.append(np.exp(-tgmm.log_density(accepted)))
        if len(accepted) > n / 2:
            scale = scale * 2.0
        elif len(accepted) < n / 10:
            scale = scale * 0.5
        scale = np.clip(scale, *SCALE_RANGE)
        uniform = superlevel.take_seed_members()
        if uniform is None:
            uniform = sampler._members(box.sample(rng, n))
        points.append(uniform)
        weights.append(np.full(len(uniform), volume))
        pool = WeightedPool(np.concatenate(points), np.concatenate(weights))
        if len(pool) > m:
            return pool, scale
        if len(pool):
            means, mixture = pool.points, pool.weights
    return WeightedPool(np.concatenate(points), np.concatenate(weights)), scale


class AdaptiveSampler(SetSampler):
    """Algorithm 2: yields the front of a buffer refilled from :func:`sample_buffer` pools."""

    name = "adaptive"

    def __init__(
        self,
        superlevel: SuperLevelSet,
        rng: np.random.Generator,
        n: int = DEFAULT_PROPOSALS,
        m: int = DEFAULT_BUFFER,
        max_rounds: int = MAX_ROUNDS,
    ) -> None:
        super().__init__(superlevel, rng)
        self.n, self.m, self.max_rounds = int(n), int(m), int(max_rounds)
        lengthscales = superlevel.model.lengthscales[: superlevel.dim]
        self.scale = np.clip(np.asarray(lengthscales, dtype=float), *SCALE_RANGE)
        self.buffer: deque[np.ndarray] = deque()
        self._pool: WeightedPool | None = None
        self._star_used = False
        self._exhausted = False

    def _theta_star_members(self) -> np.ndarray:
        """``θ*`` as a pool member the first time only (and only if it is in the set)."""
        star = self.superlevel.theta_star
        if self._star_used or star is None:
            return np.empty((0, self.superlevel.dim))
        self._star_used = True
        star = star.reshape(1, -1)
        return star if self.superlevel.contains(star)[0] else np.empty((0, self.superlevel.dim))

    def _refill(self) -> None:
        """Add ``m`` members (fewer if the set looks tiny) to the buffer."""
        if self._exhausted:
            return
        if self._pool is None or len(self._pool) < self.m:
            leftover = self._pool
            star = self.superlevel.theta_star
            means = (star.reshape(1, -1) if star is not None
                     else self.rng.uniform(-1.0, 1.0, size=(1, self.superlevel.dim)))
            pool, self.scale = sample_buffer(
                self, means, self._theta_star_members(), self.scale, self.n, self.m,
                self.max_rounds,
            )
            if leftover is not None and len(leftover):
                # Same proposal-density weights (1/q) on both: the pools merge as they are.
                pool = WeightedPool(
                    np.concatenate([leftover.points, pool.points]),
                    np.concatenate([leftover.weights, pool.weights]),
                )
            self._pool = pool
            if len(pool) == 0:
                self._exhausted = True
                return
        self.buffer.extend(self._pool.draw(self.rng, self.m))

    def _ensure_buffer(self) -> None:
        if len(self.buffer) < self.m / 2:
            self._refill()

    def _next_unit(self) -> np.ndarray | None:
        self._ensure_buffer()
        if not self.buffer:
            return None
        return self.buffer.popleft()
