"""The faucet: emits particles while a cup stands under its nozzle.

A step hook (see :meth:`Kitchen.add_hook`): every ``period`` steps, if a cup's opening is
under the nozzle (an AABB query of a sensor strip below it), one particle is created just
below the nozzle, until ``capacity`` particles have been emitted in total.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from Box2D import b2

from ltamp_cli.backends.box2d.particles import ParticleSpec, add_particles
from ltamp_cli.backends.box2d.world import Kitchen


@dataclass(frozen=True)
class FaucetSpec:
    """Nozzle at ``(x, y)``; emits one particle every ``period`` steps, ``capacity`` in all."""

    x: float
    y: float
    period: int = 2
    capacity: int = 200
    particle: ParticleSpec = field(default_factory=lambda: ParticleSpec(color=(120, 70, 30)))


class Faucet:
    """Attach with ``Faucet(kitchen, spec)``; ``emitted`` counts particles made so far."""

    def __init__(self, kitchen: Kitchen, spec: FaucetSpec) -> None:
        self.kitchen, self.spec = kitchen, spec
        self.emitted = 0
        # Off until a plan's fill action opens it; skill trials never switch it.
        self.enabled = True
        self._ticks = 0
        body = kitchen.world.CreateStaticBody(position=(spec.x, spec.y))
        body.CreatePolygonFixture(box=(0.4, 0.3, (0.0, 0.3), 0.0))
        body.userData = {"name": "faucet", "color": (160, 160, 170)}
        self.body = body
        kitchen.add_hook(self._tick)

    def cup_below(self) -> bool:
        """Whether a cup (a body named ``cup``/``held``/``target``) spans the nozzle below."""
        top = self.kitchen.layout.table_top
        query = b2.AABB(
            lowerBound=(self.spec.x - 0.05, top), upperBound=(self.spec.x + 0.05, self.spec.y)
        )
        found: list[bool] = []

        class _Callback(b2.queryCallback):
            def ReportFixture(self, fixture: b2.fixture) -> bool:
                name = (fixture.body.userData or {}).get("name", "")
                if name in ("cup", "held", "target"):
                    found.append(True)
                    return False
                return True

        self.kitchen.world.QueryAABB(_Callback(), query)
        return bool(found)

    def _tick(self, dt: float) -> None:
        del dt
        self._ticks += 1
        if not self.enabled or self.emitted >= self.spec.capacity or self._ticks % self.spec.period:
            return
        if self.cup_below():
            r = self.spec.particle.radius
            # Alternate left/right of the axis so consecutive drops do not stack exactly.
            dx = (-1) ** self.emitted * 0.3 * r
            point = np.array([[self.spec.x + dx, self.spec.y - 2 * r]])
            add_particles(self.kitchen, point, self.spec.particle)
            self.emitted += 1
