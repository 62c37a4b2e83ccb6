"""Cartesian tool-path following: continuity, FK agreement, the carried-tool tilt limit."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pybullet
import pytest

from ltamp_cli.backends.pybullet.robot import (
    CARRY_TILT_LIMIT,
    ArmCollisionChecker,
    AttachedBody,
    CartesianConfig,
    Grasp,
    KitchenScene,
    Pose,
    add_cylinder,
    build_kitchen_scene,
    cylinder_side_grasps,
    follow_tool_path,
)
from ltamp_cli.backends.pybullet.robot.pose import rotation_distance, tilt_roll_pitch

RADIUS, HEIGHT = 0.03, 0.1


@pytest.fixture(scope="module")
def cup_scene() -> Iterator[tuple[KitchenScene, int, Grasp]]:
    client = pybullet.connect(pybullet.DIRECT)
    try:
        scene = build_kitchen_scene(client, n_arms=1)
        cup = add_cylinder(
            client, RADIUS, HEIGHT, Pose(scene.table_centre + np.array([0, 0, HEIGHT / 2]))
        )
        # Approach from the arm's side (-x), hand upright.
        grasp = next(
            g
            for g in cylinder_side_grasps(RADIUS, HEIGHT)
            if g.gripper_pose(Pose()).rotation()[0, 2] > 0.9
            and g.gripper_pose(Pose()).rotation()[2, 0] > 0.5
        )
        yield scene, cup, grasp
    finally:
        pybullet.disconnect(physicsClientId=client)


def test_carry_path_is_continuous_and_tracks_the_tool(
    cup_scene: tuple[KitchenScene, int, Grasp],
) -> None:
    scene, cup, grasp = cup_scene
    arm = scene.arms[0]
    checker = ArmCollisionChecker(
        arm, scene.obstacles_for(0), AttachedBody(cup, grasp.tool_in_gripper, True)
    )
    start = Pose(scene.table_centre + np.array([-0.1, 0.0, 0.2]))
    poses = [
        start,
        Pose(start.position + np.array([0.15, 0.1, 0.05])),
        Pose.from_euler(start.position + np.array([0.1, 0.2, 0.0]), yaw=0.4),
    ]
    config = CartesianConfig()
    result = follow_tool_path(
        arm,
        poses,
        grasp.tool_in_gripper,
        np.random.default_rng(0),
        is_valid=checker,
        carrying_contents=True,
        config=config,
    )
    assert result.success and result.configurations is not None
    confs = result.configurations
    assert confs.shape == (len(result.tool_poses), 7)
    assert np.max(np.abs(np.diff(confs, axis=0))) <= config.max_joint_step
    for q, wanted in zip(confs, result.tool_poses, strict=True):
        reached = arm.forward_kinematics(q) @ grasp.tool_in_gripper
        assert np.linalg.norm(reached.position - wanted.position) <= config.ik.position_tolerance
        assert rotation_distance(reached, wanted) <= config.ik.orientation_tolerance + 1e-6
        assert all(abs(angle) <= CARRY_TILT_LIMIT for angle in tilt_roll_pitch(reached))
        assert checker(q)


def test_carried_cup_that_would_tilt_too_far_is_rejected(
    cup_scene: tuple[KitchenScene, int, Grasp],
) -> None:
    scene, cup, grasp = cup_scene
    arm = scene.arms[0]
    upright = Pose(scene.table_centre + np.array([-0.1, 0.0, 0.2]))
    tilted = Pose.from_euler(upright.position, roll=-0.8)  # 0.8 rad > π/6
    rng = np.random.default_rng(1)
    obstacles = scene.obstacles_for(0)

    empty = follow_tool_path(
        arm,
        [upright, tilted],
        grasp.tool_in_gripper,
        rng,
        is_valid=ArmCollisionChecker(
            arm, obstacles, AttachedBody(cup, grasp.tool_in_gripper, False)
        ),
    )
    assert empty.success, empty.status  # the motion itself is feasible ...

    full = follow_tool_path(
        arm,
        [upright, tilted],
        grasp.tool_in_gripper,
        rng,
        is_valid=ArmCollisionChecker(
            arm, obstacles, AttachedBody(cup, grasp.tool_in_gripper, True)
        ),
        carrying_contents=True,
    )
    assert not full.success and full.status == "carried tool tilts beyond the limit"
    # ... and it fails exactly at the first pose beyond the limit.
    assert full.failed_index is not None
    tilts = [max(map(abs, tilt_roll_pitch(pose))) for pose in full.tool_poses]
    assert tilts[full.failed_index] > CARRY_TILT_LIMIT
    assert max(tilts[: full.failed_index]) <= CARRY_TILT_LIMIT


def test_start_configuration_continuity_is_enforced(
    cup_scene: tuple[KitchenScene, int, Grasp],
) -> None:
    scene, _, grasp = cup_scene
    arm = scene.arms[0]
    start = Pose(scene.table_centre + np.array([-0.1, 0.0, 0.2]))
    rng = np.random.default_rng(2)
    first = follow_tool_path(arm, [start], grasp.tool_in_gripper, rng)
    assert first.success and first.configurations is not None
    q0 = first.configurations[0]
    near = follow_tool_path(
        arm,
        [start, Pose(start.position + np.array([0.05, 0, 0]))],
        grasp.tool_in_gripper,
        rng,
        start_configuration=q0,
    )
    assert near.success and near.configurations is not None
    assert np.max(np.abs(near.configurations[0] - q0)) <= CartesianConfig().max_joint_step
    far_start = q0.copy()
    far_start[0] += 1.0  # the path cannot begin a whole radian away in one step
    far = follow_tool_path(arm, [start], grasp.tool_in_gripper, rng, start_configuration=far_start)
    assert not far.success
