"""Cylinder grasps: geometry of the grasp frames and a rigid attachment in simulation."""

from __future__ import annotations

import numpy as np
import pybullet
import pytest

from ltamp_cli.backends.pybullet.robot import (
    Pose,
    add_cylinder,
    attach_fixed_constraint,
    build_kitchen_scene,
    cylinder_side_grasps,
    cylinder_top_grasps,
    solve_ik,
)
from ltamp_cli.backends.pybullet.robot.grasps import MAX_GRASP_WIDTH


def test_side_grasps_approach_horizontally_towards_the_axis() -> None:
    grasps = cylinder_side_grasps(0.03, 0.1, base_z=0.0, grasp_height=0.4, n_yaw=6)
    assert len(grasps) == 12
    for grasp in grasps:
        in_object = grasp.gripper_pose(Pose())
        assert np.allclose(in_object.position, [0.0, 0.0, 0.04])
        approach = in_object.rotation()[:, 2]
        closing = in_object.rotation()[:, 1]
        assert abs(approach[2]) < 1e-9 and abs(closing[2]) < 1e-9
        assert grasp.width == pytest.approx(0.06)
        # Backing off along the approach moves the hand away from the axis, horizontally.
        pre = grasp.pregrasp_pose(Pose(), retreat=0.1)
        assert np.linalg.norm(pre.position[:2]) == pytest.approx(0.1)
    approaches = {tuple(np.round(g.gripper_pose(Pose()).rotation()[:, 2], 6)) for g in grasps}
    assert len(approaches) == 6


def test_top_grasps_point_down_below_the_rim() -> None:
    for grasp in cylinder_top_grasps(0.02, 0.12, depth=0.03):
        in_object = grasp.gripper_pose(Pose())
        assert np.allclose(in_object.rotation()[:, 2], [0.0, 0.0, -1.0])
        assert in_object.position[2] == pytest.approx(0.06 - 0.03)


def test_too_wide_cylinders_are_rejected() -> None:
    with pytest.raises(ValueError, match="exceeds the gripper"):
        cylinder_side_grasps(MAX_GRASP_WIDTH, 0.1)


def test_fixed_constraint_carries_the_cup_with_the_hand() -> None:
    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
        scene = build_kitchen_scene(client, n_arms=1)
        arm = scene.arms[0]
        cup_pose = Pose(scene.table_centre + np.array([-0.1, 0.0, 0.05]))
        cup = add_cylinder(client, 0.03, 0.1, cup_pose, mass=0.2)
        grasp = cylinder_top_grasps(0.03, 0.1)[0]
        rng = np.random.default_rng(0)
        q_grasp = solve_ik(arm, grasp.gripper_pose(cup_pose), rng)
        lifted = Pose(cup_pose.position + np.array([0.0, 0.1, 0.2]))
        q_lift = solve_ik(arm, grasp.gripper_pose(lifted), rng, seed_configuration=q_grasp)
        assert q_grasp is not None and q_lift is not None
        arm.set_configuration(q_grasp)
        arm.close_gripper(grasp.width)
        attach_fixed_constraint(arm, cup, grasp.tool_in_gripper)
        for _ in range(480):  # 2 s at 240 Hz under position control
            arm.command_configuration(q_lift)
            pybullet.stepSimulation(physicsClientId=client)
        position, _ = pybullet.getBasePositionAndOrientation(cup, physicsClientId=client)
        # The cup followed the hand up off the table, to where the grasp puts it.
        expected = arm.end_effector_pose() @ grasp.tool_in_gripper
        assert position[2] > cup_pose.position[2] + 0.15
        assert np.linalg.norm(np.asarray(position) - expected.position) < 0.01
    finally:
        pybullet.disconnect(physicsClientId=client)
