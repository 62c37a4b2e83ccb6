"""A headless PyBullet world that owns its own physics client.

Every :class:`PhysicsWorld` connects its own client (``p.DIRECT`` by default) and passes
its ``client`` id to every PyBullet call, so several worlds coexist in one process and
nothing ever touches PyBullet's implicit default client.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import TracebackType

import pybullet as p

GRAVITY_M_S2 = 9.81
#: Bumped whenever a change to this engine's physics settings can change a trial's outcome;
#: benchmark caches key their trials by it (``bench/fidelity.py``).
PHYSICS_VERSION = 1


@dataclass(frozen=True)
class WorldConfig:
    """Simulation settings: ``time_step`` in seconds, solver iterations per step and the
    contact breaking threshold in metres.

    Bullet's default threshold (2 cm) keeps manifolds with every bead within 2 cm of a
    6 mm bead; 4 mm makes bead piles 2-4x faster with the same settled heap.
    """

    time_step: float = 1.0 / 240.0
    solver_iterations: int = 5
    contact_breaking_threshold: float = 0.004
    gui: bool = False


class PhysicsWorld:
    """A PyBullet client with a table plane at ``z = 0``; reset between trials."""

    def __init__(self, config: WorldConfig | None = None) -> None:
        self.config = config or WorldConfig()
        self.client = p.connect(p.GUI if self.config.gui else p.DIRECT)
        if self.client < 0:
            raise RuntimeError("could not connect to a PyBullet physics server")
        self.table: int = -1
        self.reset()

    def reset(self) -> None:
        """Remove every body and restore the settings (keeps the client: cheap and
        deterministic, unlike removing bodies one by one)."""
        p.resetSimulation(physicsClientId=self.client)
        p.setGravity(0.0, 0.0, -GRAVITY_M_S2, physicsClientId=self.client)
        p.setPhysicsEngineParameter(
            fixedTimeStep=self.config.time_step,
            numSolverIterations=self.config.solver_iterations,
            deterministicOverlappingPairs=1,
            contactBreakingThreshold=self.config.contact_breaking_threshold,
            physicsClientId=self.client,
        )
        plane = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=self.client)
        self.table = p.createMultiBody(0.0, plane, physicsClientId=self.client)
        p.changeDynamics(self.table, -1, lateralFriction=0.6, physicsClientId=self.client)

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            p.stepSimulation(physicsClientId=self.client)

    def steps_for(self, seconds: float) -> int:
        """Number of simulation steps covering ``seconds`` of simulated time."""
        return max(1, round(seconds / self.config.time_step))

    def close(self) -> None:
        if self.client >= 0:
            p.disconnect(physicsClientId=self.client)
            self.client = -1

    def __enter__(self) -> PhysicsWorld:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()
