"""SAPIEN behind the Kitchen3D skills: the same skill definition as PyBullet's, its tools
held only where they are."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sapien")

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial
from ltamp_cli.backends.sapien.skills import SapienTrialPhysics
from ltamp_cli.backends.sapien.world import SapienWorld
from ltamp_cli.backends.skills3d.physics import IDENTITY_QUAT
from ltamp_cli.backends.skills3d.push import pad_geometry
from ltamp_cli.backends.skills3d.trials import run_skill_trial

PUSH_CONTEXT = np.array([0.05, 0.3, 0.5, 0.15])
PUSH_GOOD = np.array([0.5, 0.1, 0.0, 0.15])


def test_the_sapien_push_is_the_shared_definition_run_on_sapien_physics() -> None:
    with SapienWorld() as world:
        result = run_skill_trial(SapienTrialPhysics(world), "push", PUSH_CONTEXT, PUSH_GOOD, 5)
    backend = load_backend("sapien")
    try:
        expected = backend.run_trial("push", PUSH_CONTEXT, PUSH_GOOD, 5)
    finally:
        backend.close()
    assert result.valid and result.score > 0
    assert (result.score, dict(result.info)) == (expected.score, dict(expected.info))


def test_a_sapien_tool_is_held_only_at_its_own_pose() -> None:
    with SapienWorld() as world:
        physics = SapienTrialPhysics(world)
        pad = physics.add_body(pad_geometry(), BodyMaterial(), "tool", (0.0, 0.0, 0.1))
        assert physics.hold(pad, np.array([0.0, 0.0, 0.1]), IDENTITY_QUAT, 3) == 3
        np.testing.assert_allclose(pad.pose()[0], [0.0, 0.0, 0.1], atol=1e-6)
        with pytest.raises(ValueError, match="move it to the pose first"):
            physics.hold(pad, np.array([0.05, 0.0, 0.1]), IDENTITY_QUAT, 3)
