"""The common shape of every sampler: an endless iterator of physical controls.

A sampler draws from a :class:`~ltamp_cli.sampling.superlevel.SuperLevelSet` in normalised
coordinates and yields controls in physical units, shape ``(dθ,)``. Iteration ends only when
the set looks empty (no member found within the sampler's proposal budget).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterator

import numpy as np

from ltamp_cli.sampling.superlevel import SuperLevelSet


class SetSampler(ABC, Iterator[np.ndarray]):
    """Base class: subclasses implement :meth:`_next_unit` (normalised ``(dθ,)`` or ``None``)."""

    name = "sampler"

    def __init__(self, superlevel: SuperLevelSet, rng: np.random.Generator) -> None:
        self.superlevel = superlevel
        self.rng = rng
        self.n_proposals = 0  # controls scored so far (for diagnostics and benchmarks)

    @property
    def beta(self) -> float:
        return self.superlevel.beta

    @abstractmethod
    def _next_unit(self) -> np.ndarray | None:
        """The next member in normalised coordinates, or ``None`` when none can be found."""

    def __iter__(self) -> SetSampler:
        return self

    def __next__(self) -> np.ndarray:
        unit = self._next_unit()
        if unit is None:
            raise StopIteration
        return self.superlevel.to_physical(unit)[0]

    def report_unusable(self, control: np.ndarray) -> int | None:
        """Planner feedback that ``control`` (physical) failed downstream; ignored by default.

        Returns the index of the feature whose kernel weight was changed, if any.
        """
        return None

    def _members(self, u: np.ndarray) -> np.ndarray:
        self.n_proposals += len(u)
        return u[self.superlevel.contains(u)]
