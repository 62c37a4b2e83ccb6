"""Divergence guard shared by the physics backends' trial runners.

A simulation that blows up (a non-finite state, a body thrown out of any sensible workspace or
moving absurdly fast) must not crash a collection or hand a meaningless score to a learner:
the trial is invalid, with the skill's invalid score and the reason in ``info["reason"]``.
Each backend reads its bodies' states its own way and feeds them to a :class:`DivergenceGuard`
every few steps (checking every step would cost as much as the physics for hundreds of
particles), and once more when the trial ends.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ltamp_cli.backends.protocol import TrialResult


@dataclass(frozen=True)
class StateLimits:
    """Bounds no sane trial reaches. Units: the backend's length unit (m, or Box2D units)."""

    max_position: float = 100.0
    max_speed: float = 1e3

    def violation(self, positions: np.ndarray, velocities: np.ndarray) -> tuple[int, str] | None:
        """``(first bad body, what is wrong)`` or ``None``; inputs are ``(n, d)``."""
        positions = np.atleast_2d(np.asarray(positions, dtype=float))
        velocities = np.atleast_2d(np.asarray(velocities, dtype=float))
        checks = (
            (~np.isfinite(positions).all(axis=1), "non-finite position"),
            (~np.isfinite(velocities).all(axis=1), "non-finite velocity"),
            (np.abs(positions).max(axis=1, initial=0.0) > self.max_position,
             f"|position| > {self.max_position:g}"),
            (np.linalg.norm(velocities, axis=1) > self.max_speed,
             f"speed > {self.max_speed:g}"),
        )  # fmt: skip
        for bad, what in checks:
            if bad.any():
                return int(np.argmax(bad)), f"{what} ({int(bad.sum())} of {len(bad)} bodies)"
        return None


class PhysicsDiverged(Exception):
    """Raised inside a trial when its simulation diverged; ``reason`` says how (one line)."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason

    def result(self, invalid_score: float) -> TrialResult:
        """The invalid trial this divergence makes."""
        return TrialResult(invalid_score, False, {"reason": f"physics diverged: {self.reason}"})


class DivergenceGuard:
    """Counts steps and checks states every ``every`` steps, raising :class:`PhysicsDiverged`."""

    def __init__(self, every: int = 10, limits: StateLimits | None = None) -> None:
        if every < 1:
            raise ValueError(f"every must be >= 1, got {every}")
        self.every = every
        self.limits = limits or StateLimits()
        self.steps = 0

    def due(self) -> bool:
        """Count one step; whether the states should be checked now."""
        self.steps += 1
        return self.steps % self.every == 0

    def check(
        self, positions: np.ndarray, velocities: np.ndarray, name_of: Callable[[int], str]
    ) -> None:
        """Raise if any body's state is absurd; ``name_of(i)`` names body ``i`` for the reason."""
        found = self.limits.violation(positions, velocities)
        if found is not None:
            body, what = found
            raise PhysicsDiverged(f"{what}, first {name_of(body)}, after {self.steps} steps")
