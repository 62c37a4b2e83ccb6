"""Rejection sampling from ``Â_α`` with uniform proposals in the control box."""

from __future__ import annotations

from collections import deque

import numpy as np

from ltamp_cli.sampling.base import SetSampler
from ltamp_cli.sampling.proposals import UniformBox
from ltamp_cli.sampling.superlevel import SuperLevelSet

DEFAULT_BATCH = 1000
DEFAULT_MAX_PROPOSALS = 1_000_000


class RejectionSampler(SetSampler):
    """Uniform proposals in batches of ``batch``, kept in proposal order when inside the set.

    The members of the uniform batch scored while building the set are used first (they are
    rejection samples already). Stops after ``max_proposals`` proposals without a member.
    """

    name = "rejection"

    def __init__(
        self,
        superlevel: SuperLevelSet,
        rng: np.random.Generator,
        batch: int = DEFAULT_BATCH,
        max_proposals: int = DEFAULT_MAX_PROPOSALS,
    ) -> None:
        super().__init__(superlevel, rng)
        self.batch = int(batch)
        self.max_proposals = int(max_proposals)
        self.box = UniformBox.unit(superlevel.dim)
        self._queue: deque[np.ndarray] = deque()
        seed = superlevel.take_seed_members()
        if seed is not None:
            self._queue.extend(seed)

    def _next_unit(self) -> np.ndarray | None:
        fruitless = 0
        while not self._queue:
            if fruitless >= self.max_proposals:
                return None
            members = self._members(self.box.sample(self.rng, self.batch))
            fruitless += self.batch
            self._queue.extend(members)
        return self._queue.popleft()
