"""SAPIEN behind the Kitchen3D skills: :class:`SapienTrialPhysics` implements
:class:`~ltamp_cli.backends.skills3d.physics.TrialPhysics` on a :class:`SapienWorld`.

The skills themselves (scenes, latents, tool paths, pre-checks, scores) are defined once in
:mod:`ltamp_cli.backends.skills3d`; only the physics engine differs, so the two backends
agree on clearly good and clearly bad controls (borderline ones may differ).

A tool is a PhysX kinematic body driven by per-step targets (its mass is ignored); fixed
bodies are static actors; free bodies are dynamic.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ltamp_cli.backends.kitchenware_geometry import KitchenwareGeometry
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial
from ltamp_cli.backends.pybullet.particles import BeadSpec
from ltamp_cli.backends.pybullet.paths import PosePath, velocities
from ltamp_cli.backends.sapien.bodies import (
    Beads,
    BodyType,
    SapienBody,
    create_kitchenware,
    spawn_beads_in,
)
from ltamp_cli.backends.sapien.world import SapienWorld
from ltamp_cli.backends.skills3d.physics import (
    IDENTITY_QUAT,
    BodyRole,
    SimBody,
    StepCallback,
    WorldPhysics,
)

#: How far (m) a held tool may be from the pose it is asked to hold (float32 poses).
HOLD_TOLERANCE_M = 1e-4
_BODY_TYPES: dict[BodyRole, BodyType] = {"fixed": "static", "free": "dynamic", "tool": "kinematic"}


def _sapien_body(body: SimBody) -> SapienBody:
    if not isinstance(body, SapienBody):
        raise TypeError(f"not a SAPIEN body: {type(body).__name__}")
    return body


@dataclass(frozen=True, eq=False)
class SapienTrialPhysics(WorldPhysics):
    """The trial physics of a :class:`SapienWorld` (see
    :mod:`ltamp_cli.backends.skills3d.physics` for the contract)."""

    world: SapienWorld

    def add_body(
        self,
        geometry: KitchenwareGeometry,
        material: BodyMaterial,
        role: BodyRole,
        position: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
        quaternion: Sequence[float] | np.ndarray = IDENTITY_QUAT,
    ) -> SapienBody:
        body_type = _BODY_TYPES[role]
        if role == "tool" and geometry.kind == "spoon" and self.world.config.spoon_tool == "placed":
            body_type = "placed"
        body = create_kitchenware(self.world, geometry, position, quaternion,  # type: ignore[arg-type]
                                  material=material, body_type=body_type)
        if body_type == "placed":
            body.place(position, quaternion)
        return body

    def spawn_beads_in(
        self, container: SimBody, spec: BeadSpec, rng: np.random.Generator
    ) -> Beads:
        return spawn_beads_in(self.world, _sapien_body(container), spec, rng)

    def follow(
        self, tool: SimBody, path: PosePath, on_step: StepCallback | None = None,
        step_offset: int = 0,
    ) -> int:
        """Step ``i`` targets pose ``i + 1`` (PhysX moves the kinematic tool there within the
        step, with the implied velocity); the last step targets the last pose again."""
        body = _sapien_body(tool)
        if body.body_type == "placed":
            linear, angular = velocities(path, self.time_step)

            def place(i: int) -> None:
                body.place(path.positions[i], path.quaternions[i], linear[i], angular[i])

            taken = self.run_steps(len(path), place, on_step, step_offset)
            body.place(path.positions[-1], path.quaternions[-1])
            return taken
        last = len(path) - 1

        def target(i: int) -> None:
            body.move_to(path.positions[min(i + 1, last)], path.quaternions[min(i + 1, last)])

        return self.run_steps(len(path), target, on_step, step_offset)

    def hold(
        self, tool: SimBody, position: np.ndarray, quaternion: np.ndarray, steps: int,
        on_step: StepCallback | None = None, step_offset: int = 0,
    ) -> int:
        """Step ``steps`` times: a kinematic tool stays at its last target (its creation
        pose or the end of the path it followed), which must be the pose to hold."""
        body = _sapien_body(tool)
        if body.body_type == "placed":
            taken = self.run_steps(steps, lambda _: body.place(position, quaternion), on_step,
                                   step_offset)
            body.place(position, quaternion)
            return taken
        here, turned = body.pose()
        if (np.linalg.norm(here - np.asarray(position)) > HOLD_TOLERANCE_M
                or abs(float(np.dot(turned, quaternion))) < 1.0 - 1e-6):
            raise ValueError("a SAPIEN tool is held where it is: move it to the pose first")
        return self.run_steps(steps, None, on_step, step_offset)
