"""Executing push and stir steps of kitchen3d plans (PyBullet, and SAPIEN for parity).

The arm paths are made here the way the planner's streams make them (Cartesian paths of the
hand or the held tool, solved by verified IK), so these tests do not depend on a domain.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from ltamp_cli.backends.kitchenware_geometry import VesselDims
from ltamp_cli.backends.pybullet.executor import (
    PUSH_TOLERANCE_M,
    ActionFailed,
    ExecutionSettings,
    Kitchen3DRun,
)
from ltamp_cli.backends.pybullet.robot.arm import PANDA_HOME
from ltamp_cli.backends.pybullet.robot.cartesian import follow_tool_path
from ltamp_cli.backends.pybullet.robot.pose import Pose
from ltamp_cli.backends.pybullet.skills.stir import stir_path
from ltamp_cli.backends.pybullet.tamp.planning import PlanningWorld, pose_of
from ltamp_cli.backends.pybullet.tamp.scene import SceneSpec, scene_from_world
from ltamp_cli.backends.pybullet.tamp.values import ArmPath

#: Grasp-target height (m) above the table while pushing: the closed fingertips reach
#: ~1.1 cm lower, so they meet a 5 cm block over its upper 3 cm.
PUSH_HEIGHT_M = 0.04
PALM_DOWN = Pose.from_euler(np.zeros(3), roll=math.pi)
BLOCK_START = (-0.15, 0.1)
BLOCK_GOAL = (0.0, 0.1)
CUP_AT = (0.05, -0.15)
#: The stirrer held 2 cm below its top end, palm down (the rod hangs along the approach).
STIRRER_GRASP = (Pose(np.array([0.0, 0.0, 0.18])) @ PALM_DOWN).inverse()

PUSH_WORLD = {"arms": 1, "objects": {"block": {"kind": "block", "size": [0.05, 0.05, 0.05]}},
              "regions": {"table": [[-0.3, 0.3], [-0.3, 0.3]]}}
STIR_WORLD = {"arms": 1, "objects": {
    "cup": {"kind": "cup", "top_diameter": 0.08, "base_diameter": 0.068, "height": 0.1,
            "contents": {"material": "coffee", "beads": 50}},
    "stirrer": {"kind": "stirrer", "length": 0.2}},
    "regions": {"table": [[-0.3, 0.3], [-0.3, 0.3]]}}


def _arm_path(spec: SceneSpec, tool_poses: list[Pose], grasp: Pose, kind: str,
              arm_index: int = 0, **extra: Any) -> tuple[ArmPath, ArmPath]:
    """A free/holding move from the home configuration to the path's start, and the path."""
    world = PlanningWorld(spec)
    arm = world.scene.arms[arm_index]
    path = follow_tool_path(arm, tool_poses, grasp, np.random.default_rng(0))
    assert path.success
    q = np.asarray(path.configurations)
    reach = ArmPath(arm_index, np.stack([np.asarray(PANDA_HOME), q[0]]), "free")
    return reach, ArmPath(arm_index, q, kind, **extra)


def push_paths(stop_short_m: float = 0.0, arm_index: int = 0,
               start: tuple[float, float] = BLOCK_START, goal: tuple[float, float] = BLOCK_GOAL,
               world: dict[str, Any] | None = None) -> tuple[ArmPath, ArmPath]:
    """The hand lowers behind the block, pushes it in a straight line to the goal (less
    ``stop_short_m``), backs off and lifts."""
    spec = scene_from_world(world or PUSH_WORLD)
    table_z = 0.7
    z = table_z + PUSH_HEIGHT_M
    behind = 0.025 + 0.012  # half the block + half the closed fingers
    direction = np.sign(goal[0] - start[0])
    # The arm at +x faces -x: its hand is turned half a turn (the fingers still span y).
    hand = Pose.from_euler(np.zeros(3), yaw=math.pi * arm_index) @ PALM_DOWN

    def at(x: float, height: float) -> Pose:
        return Pose(np.array([x, start[1], height])) @ hand

    first = start[0] - direction * (behind + 0.03)
    last = goal[0] - direction * (behind + stop_short_m)
    back = last - direction * 0.03
    poses = [at(first, z + 0.1), at(first, z), at(last, z), at(back, z), at(back, z + 0.1)]
    return _arm_path(spec, poses, Pose(), "push", arm_index, touching="block")


def stir_paths(control: np.ndarray) -> tuple[ArmPath, ArmPath]:
    """The held stirrer goes down into the cup and circles (the stir skill's path)."""
    spec = scene_from_world(STIR_WORLD)
    cup = spec.objects["cup"].vessel()
    assert isinstance(cup, VesselDims)
    frame = pose_of(CUP_AT, 0.7)
    skill = stir_path(cup, control)
    poses = [frame @ Pose(position, quaternion)
             for position, quaternion in zip(skill.positions, skill.quaternions, strict=True)]
    reach, stir = _arm_path(spec, poses, STIRRER_GRASP, "stir", held=("stirrer", ("top", 0)))
    return ArmPath(0, reach.configurations, "holding", held=("stirrer", ("top", 0))), stir


def _push_run(run_class: type[Kitchen3DRun], paths: tuple[ArmPath, ArmPath]) -> Kitchen3DRun:
    run = run_class(scene_from_world(PUSH_WORLD), {"block": BLOCK_START}, 0,
                    ExecutionSettings(), None)
    run.run_step("move-free", [None, paths[0], None, 0], ["q0", "t0", "q1", "r0"])
    return run


def _push(run: Kitchen3DRun, path: ArmPath) -> None:
    run.run_step("push", ["block", BLOCK_START, BLOCK_GOAL, None, None, path, 0],
                 ["block", "p1", "p2", "q1", "q2", "t1", "r0"])


def _stir_run(run_class: type[Kitchen3DRun], paths: tuple[ArmPath, ArmPath]) -> Kitchen3DRun:
    """A run whose arm holds the stirrer above the table, then reaches the stir's start."""
    spec = scene_from_world(STIR_WORLD)
    run = run_class(spec, {"cup": CUP_AT, "stirrer": (-0.2, 0.2)}, 0, ExecutionSettings(), None)
    run.held[0] = ("stirrer", STIRRER_GRASP)
    run.pinned.pop("stirrer", None)
    run.run_step("move-holding", [None, None, None, paths[0], None, 0],
                 ["stirrer", "g", "q0", "t0", "q1", "r0"])
    run.run_step("stir", ["stirrer", None, "cup", CUP_AT, None, paths[1], 0],
                 ["stirrer", "g", "cup", "pcup", "q1", "t1", "r0"])
    return run


STIR_GOOD = np.array([0.018, 0.02, 2.0, 0.1])
STIR_ABOVE_RIM = np.array([0.018, 0.11, 2.0, 0.1])


def test_a_push_moves_the_block_to_its_target() -> None:
    run = _push_run(Kitchen3DRun, push_paths())
    try:
        _push(run, push_paths()[1])
        record = run.log[-1]
        assert record["error_m"] < 0.01
        assert run.object_xy("block")[0] > BLOCK_START[0] + 0.14  # it really moved 15 cm
        holds, _ = run.check("on", ("block", "table"))
        assert holds
    finally:
        run.close()


def test_a_push_that_stops_short_fails_the_step() -> None:
    reach, short = push_paths(stop_short_m=0.06)
    run = _push_run(Kitchen3DRun, (reach, short))
    try:
        with pytest.raises(ActionFailed, match="came to rest"):
            _push(run, short)
        assert run.log[-1]["error_m"] > PUSH_TOLERANCE_M
    finally:
        run.close()


@pytest.mark.slow
def test_stirring_inside_the_cup_is_stirred_and_keeps_the_beads() -> None:
    run = _stir_run(Kitchen3DRun, stir_paths(STIR_GOOD))
    try:
        holds, measured = run.check("stirred", ("cup",))
        assert holds, measured
        before, after = run.log[-1]["counts_before"], run.log[-1]["counts_after"]
        assert before["coffee"]["cup"] == after["coffee"]["cup"] == 50  # conservation
        assert run.check("contains", ("cup", "coffee"))[0]
    finally:
        run.close()
    above = _stir_run(Kitchen3DRun, stir_paths(STIR_ABOVE_RIM))
    try:
        holds, measured = above.check("stirred", ("cup",))
        assert not holds and measured["stirs"][0]["tip_time_inside_s"] == 0.0
    finally:
        above.close()


@pytest.mark.slow
def test_push_and_stir_steps_agree_on_sapien() -> None:
    pytest.importorskip("sapien")
    from ltamp_cli.backends.sapien.executor import SapienKitchen3DRun

    paths = push_paths()
    labels = {}
    for run_class in (Kitchen3DRun, SapienKitchen3DRun):
        run = _push_run(run_class, paths)
        try:
            _push(run, paths[1])  # raises ActionFailed if the block missed its target
            pushed = run.log[-1]["error_m"] < PUSH_TOLERANCE_M
        finally:
            run.close()
        run = _stir_run(run_class, stir_paths(STIR_GOOD))
        try:
            stirred = run.check("stirred", ("cup",))[0]
            kept = run.log[-1]["counts_after"]["coffee"]["cup"]
        finally:
            run.close()
        labels[run_class.__name__] = (pushed, stirred, kept >= 48)
    assert labels["Kitchen3DRun"] == labels["SapienKitchen3DRun"] == (True, True, True)


def test_the_second_arm_pushes_while_the_first_stays_put() -> None:
    """Two-arm scene: arm 1 (at +x) pushes the block towards -x; arm 0 does not sag."""
    world = {**PUSH_WORLD, "arms": 2}
    start, goal = (0.15, 0.1), (0.0, 0.1)
    reach, push = push_paths(arm_index=1, start=start, goal=goal, world=world)
    run = Kitchen3DRun(scene_from_world(world), {"block": start}, 0, ExecutionSettings(), None)
    try:
        resting = run.scene.arms[0].end_effector_pose().position
        run.run_step("move-free", [None, reach, None, 1], ["q0", "t0", "q1", "r1"])
        run.run_step("push", ["block", start, goal, None, None, push, 1],
                     ["block", "p1", "p2", "q1", "q2", "t1", "r1"])
        assert run.log[-1]["error_m"] < 0.01
        assert np.allclose(run.scene.arms[0].end_effector_pose().position, resting, atol=1e-3)
    finally:
        run.close()
