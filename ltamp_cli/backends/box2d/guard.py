"""A Kitchen observer that stops a trial whose Box2D simulation diverged.

A non-finite velocity spreads NaN to every touching body within a step, and Box2D then
crawls (about a second per step with NaN bounding boxes) instead of failing, so bodies are
checked while the trial runs, not only at its end.
"""

from __future__ import annotations

import numpy as np
from Box2D import b2

from ltamp_cli.backends.box2d.world import Kitchen, Observer
from ltamp_cli.backends.sanity import DivergenceGuard, StateLimits


class Box2DGuard:
    """Observer checking the dynamic bodies during a trial, then calling ``observer``.

    Each step checks a rotating ``1/every`` slice of the bodies, so every body is checked every
    ``every`` steps for the cost of one full check, yet NaN, which reaches all touching bodies
    within a step, is caught at the next step (a NaN step costs far more than a check).
    Raises :class:`~ltamp_cli.backends.sanity.PhysicsDiverged` from inside ``Kitchen.step``;
    call :meth:`final_check` after the trial to check every body once more.
    """

    def __init__(
        self, observer: Observer | None = None, every: int = 20, limits: StateLimits | None = None
    ) -> None:
        self.observer = observer
        self.guard = DivergenceGuard(every, limits)
        self.kitchen: Kitchen | None = None
        self._bodies: list[b2.body] = []

    def __call__(self, kitchen: Kitchen) -> None:
        due = self.guard.due()
        if due or kitchen is not self.kitchen:
            # Bodies come and go (spawned grains, frozen spill): refresh the list now and then.
            self.kitchen = kitchen
            self._bodies = [body for body in kitchen.world.bodies if body.type == b2.dynamicBody]
        every = self.guard.every
        self._check(kitchen, self._bodies[self.guard.steps % every :: every])
        if self.observer is not None:
            self.observer(kitchen)

    def final_check(self) -> None:
        """Check every dynamic body of the last world stepped (none if it never stepped)."""
        if self.kitchen is not None:
            bodies = self.kitchen.world.bodies
            self._check(self.kitchen, [body for body in bodies if body.type == b2.dynamicBody])

    def _check(self, kitchen: Kitchen, bodies: list[b2.body]) -> None:
        limits = self.guard.limits
        reach, speed2 = limits.max_position, limits.max_speed**2
        for body in bodies:
            p, v = body.position, body.linearVelocity
            # Written out (not numpy) as it runs every step; NaN fails every comparison.
            if not (abs(p.x) <= reach and abs(p.y) <= reach and v.x * v.x + v.y * v.y <= speed2):
                break
        else:
            return
        # Something is off: describe it over every dynamic body of the world.
        dynamic = [body for body in kitchen.world.bodies if body.type == b2.dynamicBody]
        states = np.array(
            [(*body.position, *body.linearVelocity) for body in dynamic], dtype=float
        ).reshape(len(dynamic), 4)
        self.guard.check(
            states[:, :2], states[:, 2:], lambda i: str((dynamic[i].userData or {}).get("name"))
        )
