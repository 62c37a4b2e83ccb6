"""The Kitchen2D world: a Box2D world with a table, stepped at a fixed rate.

Units are Box2D units (the earlier Kitchen2D used an 80 x 50 world with the table top at
y = 20); time in seconds. A :class:`Kitchen` is cheap to build (a few milliseconds even with
500 particles), so trials build a fresh one: that makes every trial bit-for-bit
deterministic regardless of which trials ran before in the same process, which re-using one
``b2World`` cannot promise (broad-phase proxy ids, and therefore contact order, depend on
history).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from Box2D import b2

StepHook = Callable[[float], None]
Observer = Callable[["Kitchen"], None]


@dataclass(frozen=True)
class PhysicsConfig:
    """Integration and material parameters (field facts: the earlier Kitchen2D's values)."""

    gravity: tuple[float, float] = (0.0, -10.0)
    dt: float = 0.01
    velocity_iterations: int = 10
    position_iterations: int = 10


@dataclass(frozen=True)
class KitchenLayout:
    """Static furniture. Lengths in world units; x grows to the right, y up.

    The table spans ``x in [table_x0, table_x1]`` with its top at ``table_top``. The faucet
    pours at ``faucet_x`` from ``faucet_y``; the coaster is a thin plate where a cup is
    served; the sink is a basin cut into the table.
    """

    width: float = 80.0
    height: float = 50.0
    table_x0: float = -30.0
    table_x1: float = 30.0
    table_top: float = 20.0
    table_thickness: float = 1.0
    faucet_x: float = 20.0
    faucet_y: float = 32.0
    coaster_x: float = -20.0
    coaster_width: float = 4.0
    coaster_height: float = 0.2
    table_friction: float = 0.5


class Kitchen:
    """A Box2D world plus the kitchen's static parts and a fixed-rate stepper.

    ``step`` first calls every pre-step hook (controllers such as the gripper set their
    kinematic velocities there), then advances the world by ``config.dt`` and finally calls
    every observer (e.g. a frame recorder). ``time`` counts simulated seconds.
    """

    def __init__(
        self,
        config: PhysicsConfig | None = None,
        layout: KitchenLayout | None = None,
        *,
        furniture: bool = True,
    ) -> None:
        self.config = config or PhysicsConfig()
        self.layout = layout or KitchenLayout()
        self.world = b2.world(gravity=self.config.gravity, doSleep=True)
        self.time = 0.0
        self.steps = 0
        self.particles: list[b2.body] = []
        self._hooks: list[StepHook] = []
        self.observers: list[Observer] = []
        self.table: b2.body | None = None
        self.coaster: b2.body | None = None
        if furniture:
            self._build_furniture()

    def _build_furniture(self) -> None:
        lay = self.layout
        half_w = (lay.table_x1 - lay.table_x0) / 2
        cx = (lay.table_x0 + lay.table_x1) / 2
        self.table = self.world.CreateStaticBody(position=(cx, lay.table_top))
        self.table.CreatePolygonFixture(
            box=(half_w, lay.table_thickness / 2, (0, -lay.table_thickness / 2), 0),
            friction=lay.table_friction,
        )
        self.table.userData = {"name": "table", "color": (150, 111, 51)}
        # The coaster is where a finished drink is served (goal region for planning).
        self.coaster = self.world.CreateStaticBody(position=(lay.coaster_x, lay.table_top))
        self.coaster.CreatePolygonFixture(
            box=(lay.coaster_width / 2, lay.coaster_height / 2, (0, lay.coaster_height / 2), 0),
            friction=lay.table_friction,
        )
        self.coaster.userData = {"name": "coaster", "color": (60, 170, 80)}

    def add_hook(self, hook: StepHook) -> None:
        self._hooks.append(hook)

    def step(self, n: int = 1) -> None:
        cfg = self.config
        for _ in range(n):
            for hook in self._hooks:
                hook(cfg.dt)
            self.world.Step(cfg.dt, cfg.velocity_iterations, cfg.position_iterations)
            self.time += cfg.dt
            self.steps += 1
            for observer in self.observers:
                observer(self)

    def particle_positions(self) -> np.ndarray:
        """Particle centres, shape ``(n, 2)``."""
        if not self.particles:
            return np.zeros((0, 2))
        return np.array([tuple(p.position) for p in self.particles], dtype=float)

    def particle_speeds(self) -> np.ndarray:
        """Particle speeds, shape ``(n,)``."""
        if not self.particles:
            return np.zeros(0)
        return np.array([p.linearVelocity.length for p in self.particles], dtype=float)

    def in_bounds(self, points: np.ndarray) -> np.ndarray:
        """Which points (shape ``(n, 2)``) are finite and inside the world box."""
        lay = self.layout
        finite = np.all(np.isfinite(points), axis=1)
        inside = (
            (np.abs(points[:, 0]) <= lay.width / 2)
            & (points[:, 1] >= 0.0)
            & (points[:, 1] <= lay.height)
        )
        return finite & inside
