"""The Kitchen3D skills run on any engine through the small physics interface.

A recording engine that forwards every call to PyBullet's implementation shows that a skill
uses nothing but :class:`~ltamp_cli.backends.skills3d.physics.TrialPhysics` (its result is
the backend's, bit for bit) and in which roles it creates its bodies.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.kitchenware_geometry import KitchenwareGeometry, vessel_geometry
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial
from ltamp_cli.backends.pybullet.particles import BeadSpec
from ltamp_cli.backends.pybullet.paths import PosePath
from ltamp_cli.backends.pybullet.skills.physics import BulletTrialPhysics
from ltamp_cli.backends.pybullet.world import PhysicsWorld, skill_world_config
from ltamp_cli.backends.skills3d.physics import (
    IDENTITY_QUAT,
    BeadSet,
    BodyRole,
    SimBody,
    StepCallback,
    TrialPhysics,
)
from ltamp_cli.backends.skills3d.pour import NOMINAL_BOWL, NOMINAL_CUP, PourContext
from ltamp_cli.backends.skills3d.push import PushSettings
from ltamp_cli.backends.skills3d.trials import run_skill_trial

PUSH_CONTEXT = np.array([0.05, 0.3, 0.5, 0.15])
PUSH_GOOD = np.array([0.5, 0.1, 0.0, 0.15])
POUR_CONTEXT = PourContext(NOMINAL_BOWL, NOMINAL_CUP).to_array()
POUR_GOOD = np.array([-3 * np.pi / 4, -0.5, 0.5, 0.15, 0.12])


@dataclass
class RecordingPhysics:
    """Forwards to ``inner`` and records the roles of the bodies created, the containers
    filled with beads and the steps taken."""

    inner: TrialPhysics
    roles: list[tuple[str, BodyRole]] = field(default_factory=list)
    filled: list[str] = field(default_factory=list)
    steps: int = 0

    @property
    def time_step(self) -> float:
        return self.inner.time_step

    def reset(self) -> None:
        self.roles.clear()
        self.inner.reset()

    def steps_for(self, seconds: float) -> int:
        return self.inner.steps_for(seconds)

    def add_body(self, geometry: KitchenwareGeometry, material: BodyMaterial, role: BodyRole,
                 position: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
                 quaternion: Sequence[float] | np.ndarray = IDENTITY_QUAT) -> SimBody:
        self.roles.append((geometry.kind, role))
        return self.inner.add_body(geometry, material, role, position, quaternion)

    def spawn_beads_in(self, container: SimBody, spec: BeadSpec,
                       rng: np.random.Generator) -> BeadSet:
        self.filled.append(container.geometry.kind)
        return self.inner.spawn_beads_in(container, spec, rng)

    def follow(self, tool: SimBody, path: PosePath, on_step: StepCallback | None = None,
               step_offset: int = 0) -> int:
        taken = self.inner.follow(tool, path, on_step, step_offset)
        self.steps += taken
        return taken

    def hold(self, tool: SimBody, position: np.ndarray, quaternion: np.ndarray, steps: int,
             on_step: StepCallback | None = None, step_offset: int = 0) -> int:
        taken = self.inner.hold(tool, position, quaternion, steps, on_step, step_offset)
        self.steps += taken
        return taken


@pytest.fixture(scope="module")
def world() -> PhysicsWorld:
    with PhysicsWorld() as physics_world:
        yield physics_world


@pytest.mark.parametrize(
    ("skill", "context", "control", "roles", "filled"),
    [
        ("push", PUSH_CONTEXT, PUSH_GOOD, [("block", "free"), ("pusher", "tool")], []),
        ("pour", POUR_CONTEXT, POUR_GOOD, [("bowl", "fixed"), ("cup", "tool")], ["cup"]),
    ],
)
def test_a_skill_uses_only_the_interface_and_matches_the_backend(
    skill: str, context: np.ndarray, control: np.ndarray,
    roles: list[tuple[str, str]], filled: list[str],
) -> None:
    # The backend runs each skill in a world of the skill's settings (the push's contact
    # breaking threshold is 2 cm, the pour's 4 mm).
    with PhysicsWorld(skill_world_config(skill)) as skill_world:
        recording = RecordingPhysics(BulletTrialPhysics(skill_world))
        result = run_skill_trial(recording, skill, context, control, seed=3)
    backend = load_backend("pybullet")
    try:
        expected = backend.run_trial(skill, context, control, 3)
    finally:
        backend.close()
    assert result.valid and result.score > 0  # a clear-cut good control
    assert (result.score, dict(result.info)) == (expected.score, dict(expected.info))
    assert recording.roles == roles and recording.filled == filled
    assert recording.steps == result.info["sim_steps"]


def test_run_skill_trial_refuses_unknown_skills_and_other_skills_settings(
    world: PhysicsWorld,
) -> None:
    physics = BulletTrialPhysics(world)
    with pytest.raises(KeyError, match="known: pour, scoop, push, stir"):
        run_skill_trial(physics, "wipe", PUSH_CONTEXT, PUSH_GOOD, 0)
    with pytest.raises(TypeError, match="pour takes PourSettings, not PushSettings"):
        run_skill_trial(physics, "pour", POUR_CONTEXT, POUR_GOOD, 0, PushSettings())


def test_bullet_fixed_bodies_ignore_the_mass_and_moving_ones_need_one(
    world: PhysicsWorld,
) -> None:
    physics = BulletTrialPhysics(world)
    physics.reset()
    bowl = physics.add_body(vessel_geometry(NOMINAL_BOWL, "bowl"), BodyMaterial(mass=1.0),
                            "fixed", (0.3, 0.0, 0.2))
    cup = physics.add_body(vessel_geometry(NOMINAL_CUP, "cup"), BodyMaterial(mass=0.1),
                           "free", (-0.3, 0.0, 0.2))
    world.step(60)  # 0.25 s: a free body falls 0.2 m onto the table, a fixed one stays
    np.testing.assert_allclose(bowl.pose()[0], [0.3, 0.0, 0.2], atol=1e-9)
    assert cup.pose()[0][2] < 0.01
    with pytest.raises(ValueError, match="free body needs a positive mass"):
        physics.add_body(vessel_geometry(NOMINAL_CUP, "cup"), BodyMaterial(mass=0.0), "free")
