"""PyBullet behind the Kitchen3D skills: :class:`BulletTrialPhysics` implements
:class:`~ltamp_cli.backends.skills3d.physics.TrialPhysics` on a :class:`PhysicsWorld`.

Bullet has no kinematic bodies with velocity, so a tool is a dynamic body (with its
material's mass) that is placed at every step: at each pose with the velocity that reaches
the next one, so contacts see a moving tool, and at rest while held.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ltamp_cli.backends.kitchenware_geometry import KitchenwareGeometry
from ltamp_cli.backends.pybullet.kitchenware import (
    BodyMaterial,
    KitchenwareBody,
    create_kitchenware,
)
from ltamp_cli.backends.pybullet.particles import BeadSpec, bead_positions, spawn_beads_in
from ltamp_cli.backends.pybullet.paths import PosePath, velocities
from ltamp_cli.backends.pybullet.world import PhysicsWorld
from ltamp_cli.backends.skills3d.physics import (
    IDENTITY_QUAT,
    BodyRole,
    SimBody,
    StepCallback,
    WorldPhysics,
)


@dataclass(frozen=True, eq=False)
class BulletBeads:
    """The beads of one trial: PyBullet body ids ``(n,)`` in ``client``."""

    client: int
    ids: np.ndarray

    def __len__(self) -> int:
        return len(self.ids)

    def positions(self) -> np.ndarray:
        """World positions ``(n, 3)`` of the bead centres, metres."""
        return bead_positions(self.client, self.ids)


def _bullet_body(body: SimBody) -> KitchenwareBody:
    if not isinstance(body, KitchenwareBody):
        raise TypeError(f"not a PyBullet body: {type(body).__name__}")
    return body


@dataclass(frozen=True, eq=False)
class BulletTrialPhysics(WorldPhysics):
    """The trial physics of a :class:`PhysicsWorld` (see
    :mod:`ltamp_cli.backends.skills3d.physics` for the contract)."""

    world: PhysicsWorld

    def add_body(
        self,
        geometry: KitchenwareGeometry,
        material: BodyMaterial,
        role: BodyRole,
        position: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
        quaternion: Sequence[float] | np.ndarray = IDENTITY_QUAT,
    ) -> KitchenwareBody:
        """A body of ``geometry``; Bullet fixes a body of mass 0, so a fixed body gets it."""
        if role == "fixed":
            material = replace(material, mass=0.0)
        elif not material.mass > 0:
            raise ValueError(f"a {role} body needs a positive mass, got {material.mass}")
        return create_kitchenware(self.world.client, geometry, position, quaternion,  # type: ignore[arg-type]
                                  material=material)

    def spawn_beads_in(
        self, container: SimBody, spec: BeadSpec, rng: np.random.Generator
    ) -> BulletBeads:
        ids = spawn_beads_in(_bullet_body(container), spec, rng)
        return BulletBeads(self.world.client, ids)

    def follow(
        self, tool: SimBody, path: PosePath, on_step: StepCallback | None = None,
        step_offset: int = 0,
    ) -> int:
        """Place ``tool`` at each pose of ``path`` with the velocity reaching the next one,
        one step each; it ends at the last pose, at rest."""
        body = _bullet_body(tool)
        linear, angular = velocities(path, self.time_step)

        def place(i: int) -> None:
            body.set_pose(path.positions[i], path.quaternions[i], linear[i], angular[i])

        taken = self.run_steps(len(path), place, on_step, step_offset)
        body.set_pose(path.positions[-1], path.quaternions[-1])
        return taken

    def hold(
        self, tool: SimBody, position: np.ndarray, quaternion: np.ndarray, steps: int,
        on_step: StepCallback | None = None, step_offset: int = 0,
    ) -> int:
        """Place ``tool`` at rest at the pose before each of ``steps`` steps."""
        body = _bullet_body(tool)
        taken = self.run_steps(steps, lambda _: body.set_pose(position, quaternion), on_step,
                               step_offset)
        body.set_pose(position, quaternion)
        return taken
