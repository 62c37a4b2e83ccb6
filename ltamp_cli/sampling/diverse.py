"""Diversity-aware sampling from ``Â_α`` (Algorithm 4) with optional kernel learning (5).

The first sample is ``θ*``; each next one is the member of the adaptive sampler's buffer with
the largest conditional variance ``η_S`` given the samples ``S`` already returned. With
``learn=True`` (``diverse-lk``) :meth:`DiverseSampler.report_unusable` updates the
:class:`~ltamp_cli.sampling.kernel_learning.DiversityKernel` in place, and every later
selection uses the updated inverse lengthscales.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_triangular

from ltamp_cli.sampling.adaptive import DEFAULT_BUFFER, MAX_ROUNDS, AdaptiveSampler
from ltamp_cli.sampling.kernel_learning import DiversityKernel
from ltamp_cli.sampling.superlevel import DEFAULT_PROPOSALS, SuperLevelSet

MATCH_TOLERANCE = 1e-9


class _GreedyVariance:
    """``η_S`` over candidates with an incrementally grown Cholesky factor of ``Ξ_S + ζ² I``.

    The factor is rebuilt whenever the kernel's ``updates`` counter moved (new lengthscales).
    """

    def __init__(self, kernel: DiversityKernel) -> None:
        self.kernel = kernel
        self.selected: list[np.ndarray] = []
        self._factor = np.zeros((0, 0))
        self._version = kernel.updates

    def _sync(self) -> None:
        if self._version != self.kernel.updates:
            self._version = self.kernel.updates
            selected = np.array(self.selected).reshape(-1, self.kernel.dim)
            self._factor = (self.kernel.noisy_factor(selected) if len(selected)
                            else np.zeros((0, 0)))

    def add(self, point: np.ndarray) -> None:
        self._sync()
        k = len(self.selected)
        if k == 0:
            self._factor = np.array([[np.sqrt(1.0 + self.kernel.zeta**2)]])
        else:
            cross = self.kernel.gram(np.array(self.selected), point)[:, 0]
            row = solve_triangular(self._factor, cross, lower=True)
            corner = np.sqrt(max(1.0 + self.kernel.zeta**2 - row @ row, 1e-12))
            factor = np.zeros((k + 1, k + 1))
            factor[:k, :k] = self._factor
            factor[k, :k] = row
            factor[k, k] = corner
            self._factor = factor
        self.selected.append(np.asarray(point, dtype=float).copy())

    def variance(self, candidates: np.ndarray) -> np.ndarray:
        self._sync()
        if not self.selected:
            return np.ones(len(candidates))
        cross = self.kernel.gram(np.array(self.selected), candidates)
        solved = solve_triangular(self._factor, cross, lower=True)
        return 1.0 - (solved * solved).sum(0)


class DiverseSampler(AdaptiveSampler):
    """Algorithm 4 over the adaptive buffer; ``learn`` turns on Algorithm 5's feedback."""

    name = "diverse"

    def __init__(
        self,
        superlevel: SuperLevelSet,
        rng: np.random.Generator,
        kernel: DiversityKernel | None = None,
        learn: bool = False,
        n: int = DEFAULT_PROPOSALS,
        m: int = DEFAULT_BUFFER,
        max_rounds: int = MAX_ROUNDS,
    ) -> None:
        super().__init__(superlevel, rng, n, m, max_rounds)
        self.kernel = kernel if kernel is not None else DiversityKernel.unit(superlevel.dim)
        if self.kernel.dim != superlevel.dim:
            raise ValueError(
                f"diversity kernel has {self.kernel.dim} features, the skill {superlevel.dim}"
            )
        self.learn = learn
        if learn:
            self.name = "diverse-lk"
        self._greedy = _GreedyVariance(self.kernel)
        self._star_pending = True

    @property
    def selected(self) -> np.ndarray:
        """``S``: the samples returned so far, normalised ``(k, dθ)``, in order."""
        return np.array(self._greedy.selected).reshape(-1, self.superlevel.dim)

    def _next_unit(self) -> np.ndarray | None:
        choice = None
        if self._star_pending:
            self._star_pending = False
            star = self._theta_star_members()  # θ* first (if it is in the set)
            if len(star):
                choice = star[0]
        if choice is None:
            self._ensure_buffer()
            if not self.buffer:
                return None
            candidates = np.array(self.buffer)
            best = int(np.argmax(self._greedy.variance(candidates)))
            choice = candidates[best]
            del self.buffer[best]
        self._greedy.add(choice)
        return choice

    def report_unusable(self, control: np.ndarray) -> int | None:
        """Kernel learning from an unusable ``control`` (physical ``(dθ,)``) this sampler gave.

        Only with ``learn=True``; returns the feature whose inverse lengthscale shrank.
        """
        if not self.learn:
            return None
        unit = self.superlevel.to_unit(control)[0]
        selected = self.selected
        if len(selected) == 0:
            return None
        distance = np.abs(selected - unit).max(axis=1)
        index = int(np.argmin(distance))
        if distance[index] > MATCH_TOLERANCE * max(1.0, float(np.abs(unit).max())) + 1e-9:
            return None  # not one of ours
        return self.kernel.update(unit, selected[:index])
