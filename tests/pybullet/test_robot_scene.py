"""One- and two-arm Kitchen3D scenes: placement, and both arms reaching the table centre."""

from __future__ import annotations

import numpy as np
import pybullet
import pytest

from ltamp_cli.backends.pybullet.robot import (
    PANDA_HOME,
    ArmCollisionChecker,
    Pose,
    build_kitchen_scene,
    solve_ik,
)
from ltamp_cli.backends.pybullet.robot.ik import pose_error


def test_two_arm_scene_both_arms_reach_the_table_centre() -> None:
    client = pybullet.connect(pybullet.DIRECT)
    try:
        scene = build_kitchen_scene(client, n_arms=2)
        assert len(scene.arms) == 2
        bases = [arm.base_pose.position for arm in scene.arms]
        assert bases[0][0] < 0 < bases[1][0]  # opposite sides of the table
        rng = np.random.default_rng(0)
        target = Pose.from_euler(scene.table_centre + np.array([0.0, 0.0, 0.1]), roll=np.pi)
        for index, arm in enumerate(scene.arms):
            other = scene.arms[1 - index]
            other.set_configuration(np.asarray(PANDA_HOME))
            checker = ArmCollisionChecker(arm, scene.obstacles_for(index))
            assert checker(np.asarray(PANDA_HOME))
            q = solve_ik(arm, target, rng, is_valid=checker)
            assert q is not None, f"arm {index} cannot reach the table centre"
            position_error, orientation_error = pose_error(arm, q, target)
            assert position_error < 1e-3 and orientation_error < 1e-2
    finally:
        pybullet.disconnect(physicsClientId=client)


def test_one_arm_scene_and_bad_arm_count() -> None:
    client = pybullet.connect(pybullet.DIRECT)
    try:
        scene = build_kitchen_scene(client, n_arms=1)
        assert len(scene.arms) == 1
        assert scene.table_id in scene.obstacles_for(0)
        assert scene.arms[0].body_id not in scene.obstacles_for(0)
        with pytest.raises(ValueError, match="n_arms"):
            build_kitchen_scene(client, n_arms=3)
    finally:
        pybullet.disconnect(physicsClientId=client)
