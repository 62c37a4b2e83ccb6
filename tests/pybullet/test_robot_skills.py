"""The Panda in the loop of the scoop, push and stir (``robot="panda"``): the tools' grasps,
the arm keeping the skill's timing, an unreachable setup failing with "reach", and controls
that succeed free-floating succeeding with the robot."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.kitchenware_geometry import SpoonDims, spoon_geometry
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial
from ltamp_cli.backends.pybullet.paths import PosePath, rotation_about_axis, timed_poses
from ltamp_cli.backends.pybullet.robot.arm import PANDA_HAND_LINK
from ltamp_cli.backends.pybullet.robot.cartesian import CartesianConfig, densify_tool_path
from ltamp_cli.backends.pybullet.robot.grasps import rim_grasps
from ltamp_cli.backends.pybullet.robot.pose import Pose
from ltamp_cli.backends.pybullet.skills.robot import (
    RobotSettings,
    RobotTrialPhysics,
    path_progress,
    skill_timed_configurations,
    spoon_grasps,
)
from ltamp_cli.backends.pybullet.world import PhysicsWorld
from ltamp_cli.backends.skills3d.scoop import prepare_scoop


def test_rim_grasps_pinch_the_wall_from_above() -> None:
    grasps = rim_grasps(0.05, 0.1, 0.004, depth=0.015, n_yaw=8)
    assert len(grasps) == 16
    for grasp in grasps:
        gripper = grasp.gripper_pose(Pose())
        # On the wall's mid-surface, 1.5 cm below the rim, approaching straight down with
        # the fingers closing radially across the 4 mm wall.
        assert np.hypot(*gripper.position[:2]) == pytest.approx(0.048)
        assert gripper.position[2] == pytest.approx(0.085)
        np.testing.assert_allclose(gripper.rotation()[:, 2], [0.0, 0.0, -1.0], atol=1e-12)
        radial = np.append(gripper.position[:2], 0.0) / 0.048
        assert abs(float(gripper.rotation()[:, 1] @ radial)) == pytest.approx(1.0)
        assert grasp.width == 0.004
    with pytest.raises(ValueError):
        rim_grasps(0.05, 0.1, 0.09)  # a wall wider than the gripper opens
    # Leaning out by π/4: the approach comes from above and outside, the fingers close
    # across the wall's top corner (a wider gap), the grasp point is unchanged.
    for grasp in rim_grasps(0.05, 0.1, 0.004, n_yaw=4, lean=math.pi / 4):
        gripper = grasp.gripper_pose(Pose())
        radial = np.append(gripper.position[:2], 0.0) / 0.048
        expected = -(np.array([0.0, 0.0, 1.0]) + radial) / math.sqrt(2.0)
        np.testing.assert_allclose(gripper.rotation()[:, 2], expected, atol=1e-12)
        assert gripper.position[2] == pytest.approx(0.085)
        assert grasp.width == pytest.approx(0.004 * math.sqrt(2.0))


def test_spoon_grasps_hold_the_handle_near_its_end() -> None:
    geometry = spoon_geometry(SpoonDims(0.2))
    handle = geometry.pieces[-1]
    grasps = spoon_grasps(geometry)
    assert len(grasps) == 8
    widths = sorted({round(g.width, 4) for g in grasps})
    assert widths == [0.004, 0.012]  # across the thickness, across the width
    for grasp in grasps:
        target = grasp.gripper_pose(Pose()).position
        # Inside the handle's bounding box, in its outer half (away from the head).
        assert np.all(target >= handle.min(axis=0) - 1e-9)
        assert np.all(target <= handle.max(axis=0) + 1e-9)
        assert target[1] > handle[:, 1].mean()


def test_path_progress_and_skill_timing() -> None:
    positions = np.array([[0.0, 0.0, 0.3], [0.0, 0.1, 0.3], [0.0, 0.1, 0.3], [0.1, 0.1, 0.2]])
    quaternions = np.array([rotation_about_axis("x", a) for a in (0.0, 0.0, 0.6, 0.6)])
    preview = PosePath(positions, quaternions)
    dt = 1.0 / 240.0
    timed = timed_poses(preview, speed=0.1, angular_speed=1.0, dt=dt)
    progress = path_progress(preview, timed)
    assert progress[0] == 0.0 and progress[-1] == pytest.approx(3.0)
    assert np.all(np.diff(progress) > 0)
    # 1 s along the first segment at 0.1 m/s: half way after 0.5 s.
    assert progress[120] == pytest.approx(0.5, abs=1e-9)
    # The turn in place (segment 1) is timed by the angular speed: 0.6 s.
    turning = (progress > 1.0) & (progress <= 2.0)
    assert turning.sum() == round(0.6 / dt)
    # Configurations that are the dense pose index in every joint come back as the
    # position along the densified path.
    config = CartesianConfig()
    dense = densify_tool_path([Pose(p, q) for p, q in zip(positions, quaternions, strict=True)],
                              config.max_translation, config.max_rotation)
    q = np.tile(np.arange(len(dense), dtype=float)[:, None], (1, 7))
    targets = skill_timed_configurations(q, preview, timed, config)
    assert targets.shape == (len(timed), 7)
    assert targets[0, 0] == 0.0 and targets[-1, 0] == pytest.approx(len(dense) - 1)
    assert targets[120, 0] == pytest.approx(5.0)  # 10 cm in 1 cm steps: halfway at 5
    with pytest.raises(ValueError, match="densified"):
        skill_timed_configurations(q[:-1], preview, timed, config)


@pytest.fixture()
def world() -> Iterator[PhysicsWorld]:
    with PhysicsWorld() as physics_world:
        yield physics_world


def test_a_tool_away_from_the_path_start_moves_free(world: PhysicsWorld) -> None:
    # The scoop's capacity measurement places the spoon elsewhere: no arm, no grasp.
    context = np.array([0.2, 0.08, 0.12, 0.2])
    control = np.array([0.3, -0.3, 0.0, 0.0, 0.02])
    trial = prepare_scoop(context, control, check=False)
    physics = RobotTrialPhysics(world, trial.path, RobotSettings(), 0, (math.pi / 2,))
    physics.reset()
    material = BodyMaterial(mass=0.05)
    spoon = physics.add_body(trial.tool, material, "tool", (0.0, 0.0, 0.3))
    assert physics.state.arm is None and physics.state.tool is None
    physics.hold(spoon, np.array([0.0, 0.0, 0.3]), np.array([0.0, 0.0, 0.0, 1.0]), 10)
    assert np.linalg.norm(spoon.pose()[0] - [0.0, 0.0, 0.3]) < 1e-6
    # At the path's start the arm grasps it.
    physics.reset()
    held = physics.add_body(trial.tool, material, "tool", trial.path.positions[0],
                            trial.path.quaternions[0])
    assert physics.state.tool is held and physics.state.plan is not None
    assert physics.state.plan.grasp.kind == "bar"


@pytest.mark.parametrize("skill", ["scoop", "push", "stir"])
def test_an_unreachable_setup_fails_with_reach(skill: str) -> None:
    # The base 1.5 m from the tool: no pose of any path is within the Panda's reach.
    robot = load_backend("pybullet", robot="panda",
                         robot_settings=RobotSettings(base_distance=1.5))
    near = load_backend("pybullet", robot="panda")
    try:
        rng = np.random.default_rng(3)
        spec = robot.skills()[skill]
        while True:
            context = robot.sample_context(skill, rng)
            control = spec.control.sample_uniform(rng, 1)[0]
            if robot.is_valid(skill, context, control[None])[0]:
                break
        result = robot.run_trial(skill, context, control, 0)
        assert (result.score, result.valid, result.info["reason"]) == (
            spec.invalid_score, True, "reach")
        # The same input with the base at its usual distance is planned (whatever the
        # outcome, it is not a reach failure).
        assert near.run_trial(skill, context, control, 0).info.get("reason") != "reach"
    finally:
        robot.close()
        near.close()


#: Inputs of the fidelity bench's robot rows (seed 0, ``bench/fidelity.py``) on which the
#: free-floating tool succeeded: {skill: (context, control, trial seed)}. The push's cube is
#: pushed by the Panda's closed fingertips; the pour's 8.7 cm cup is wider than the
#: gripper, so the Panda holds it by the rim.
SUCCEEDED_FREE = {
    "push": ([0.0728490642431169, 0.25933422043929416, 0.4470381800841422,
              0.10542417788739156],
             [0.3748742832455157, 0.2392249043841796, 0.02782007811247733,
              0.09095909600466118], 7),  # travel = the row's distance + stop offset
    "pour": ([0.20112964554605928, 0.09981306125834216, 0.10875560143890388,
              0.08686765286710112, 0.08897368865765463, 0.07171284518973498],
             [-1.967520095061813, -0.004259871117171854, -0.20895120455377236,
              0.6391332526566073, 0.1308194384158791], 24),
    # The stirrer rod reaches the cup's floor: the planner checks it at its centre of mass
    # (checked 10 cm low, in the table, this input failed "collision").
    "stir": ([0.0752048987858984, 0.08303892806674293, 0.06404308724081902],
             [0.01707840403387267, 0.024106364356827333, 2.3059255723398966,
              0.2701063988119544], 30),
}


@pytest.mark.parametrize("skill", sorted(SUCCEEDED_FREE))
def test_a_free_floating_success_succeeds_with_the_robot(skill: str) -> None:
    context, control, seed = (np.asarray(v) if i < 2 else v
                              for i, v in enumerate(SUCCEEDED_FREE[skill]))
    free = load_backend("pybullet")
    robot = load_backend("pybullet", robot="panda")
    try:
        assert free.run_trial(skill, context, control, seed).score > 0
        result = robot.run_trial(skill, context, control, seed)
        assert result.valid and "reason" not in result.info, result.info
        assert result.score > 0, result.info
    finally:
        free.close()
        robot.close()


def test_the_palm_touching_a_tall_block_is_a_collision_and_the_lean_clears_it() -> None:
    # The push's input above (fidelity input 7): the cube's top is 4.6 cm above the pad's
    # centre, above the palm of a hand held straight down (~3.45 cm). Held straight down
    # (push_pitch 0) the palm touches the block: an arm collision, a failed trial. Held
    # leaning back (the default) the palm clears it and the pad alone pushes it to its goal.
    context, control, seed = (np.asarray(v) if i < 2 else v
                              for i, v in enumerate(SUCCEEDED_FREE["push"]))
    assert context[0] * (1.0 - control[0]) > 0.04
    straight = load_backend("pybullet", robot="panda",
                            robot_settings=RobotSettings(push_pitch=0.0))
    leaning = load_backend("pybullet", robot="panda")
    try:
        failed = straight.run_trial("push", context, control, seed)
        assert failed.valid and failed.info.get("reason") == "collision", failed.info
        assert failed.info["robot_detail"].startswith(f"arm link {PANDA_HAND_LINK} touched")
        assert failed.score == straight.skills()["push"].invalid_score
        carried = leaning.run_trial("push", context, control, seed)
        assert "reason" not in carried.info and carried.score > 0, carried.info
    finally:
        straight.close()
        leaning.close()
