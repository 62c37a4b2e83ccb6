"""A round object is pushed with the fingers open across the push line (issue #20).

push_to_reach seed 1 planned a 0.66 m push of the 0.2 m bowl; the closed fingers touched the
bowl at one point, the bowl turned and slid off the line (0.12 m) and came to rest 0.187 m
from its target. Two contacts either side of the line keep a round object on it: the stream
plans the push for the open fingers' contact distance and the executor opens them (both
through :func:`skill_paths.push_finger_gap`); closed fingers stay for fingers along the line
and for flat-faced objects."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.backends.pybullet.executor import (
    PUSH_TOLERANCE_M,
    ExecutionSettings,
    Kitchen3DRun,
)
from ltamp_cli.backends.pybullet.robot.arm import PANDA_HOME
from ltamp_cli.backends.pybullet.tamp import skill_paths
from ltamp_cli.backends.pybullet.tamp.planning import PlanningWorld
from ltamp_cli.backends.pybullet.tamp.scene import scene_from_world
from ltamp_cli.backends.pybullet.tamp.values import ArmConf
from ltamp_cli.planner.problem import load_problem

ROOT = Path(__file__).resolve().parents[2]
BOWL_AT, CUP_AT = (0.45, 0.3), (-0.45, -0.3)
#: push_to_reach seed 1's target for the bowl (in the middle region), 0.66 m away.
FAR_GOAL = (-0.095, -0.0754)


def _spec():  # type: ignore[no-untyped-def]
    return scene_from_world(load_problem(ROOT / "problems/kitchen3d/push_to_reach.yaml").world)


def test_fingers_open_only_across_the_line_and_only_for_round_objects() -> None:
    spec = _spec()
    bowl = spec.objects["bowl"]
    east = np.array([1.0, 0.0])
    assert skill_paths.fingers_across(np.array([0.0, 0.08, 0.0]), east)
    assert skill_paths.fingers_across(np.array([0.03, -0.07]), east)  # 67 degrees off
    assert not skill_paths.fingers_across(np.array([0.08, 0.01]), east)
    assert not skill_paths.fingers_across(np.zeros(2), east)
    assert skill_paths.push_finger_gap(bowl, True) == skill_paths.PUSH_FINGER_GAP_M
    assert skill_paths.push_finger_gap(bowl, False) == 0.0
    r = bowl.footprint()[0]
    closed = skill_paths.push_contact_distance(bowl, 0.0)
    assert closed == pytest.approx(r + skill_paths.FINGER_HALF_M)
    # Open fingers meet the round wall 4 cm either side of the line: sqrt(r^2 - 0.04^2).
    opened = skill_paths.push_contact_distance(bowl, skill_paths.PUSH_FINGER_GAP_M)
    assert opened == pytest.approx(math.sqrt(r * r - 0.04 ** 2) + skill_paths.FINGER_HALF_M)
    # The across push ends that much closer behind the goal than the along one.
    heading = math.atan2(FAR_GOAL[1] - BOWL_AT[1], FAR_GOAL[0] - BOWL_AT[0])
    direction = np.array([math.cos(heading), math.sin(heading)])
    for yaw, behind in ((heading, opened), (heading + math.pi / 2, closed)):
        poses = skill_paths.push_hand_poses(bowl, BOWL_AT, FAR_GOAL, 0.0, yaw)
        end = np.asarray(poses[2].position[:2])
        assert float((np.asarray(FAR_GOAL) - end) @ direction) == pytest.approx(behind)


def _kitchen_runs() -> list[type]:
    try:
        from ltamp_cli.backends.sapien.executor import SapienKitchen3DRun
    except ImportError:
        return [Kitchen3DRun]
    return [Kitchen3DRun, SapienKitchen3DRun]


def _push(run_class: type, offset: float = 0.0) -> tuple[dict, float]:
    """Plan push_to_reach's far push with the fingers across the line, execute it with
    ``run_class``; the push's log entry and the bowl's distance (m) from the planned line at
    the end. ``offset`` (m): the bowl really stands that far to the left of the planned line."""
    spec = _spec()
    heading = math.atan2(FAR_GOAL[1] - BOWL_AT[1], FAR_GOAL[0] - BOWL_AT[0])
    planning = PlanningWorld(spec)
    try:
        poses = skill_paths.push_hand_poses(spec.objects["bowl"], BOWL_AT, FAR_GOAL,
                                            planning.table_z, heading)
        push = None
        for seed in range(5):  # the Cartesian follower's IK restarts are random
            push = planning.follow_hand_path(poses, 1, np.random.default_rng(seed), "push",
                                             touching="bowl")
            if push is not None:
                break
        assert push is not None
        reach = planning.plan_motion(ArmConf.of(1, np.asarray(PANDA_HOME)), push.start, None,
                                     seed=0)
        assert reach is not None
    finally:
        planning.close()
    direction = np.subtract(FAR_GOAL, BOWL_AT) / np.linalg.norm(np.subtract(FAR_GOAL, BOWL_AT))
    actual = (BOWL_AT[0] - offset * direction[1], BOWL_AT[1] + offset * direction[0])
    run = run_class(spec, {"cup": CUP_AT, "bowl": actual}, 0, ExecutionSettings(), None)
    off_line = [0.0]
    try:
        run.run_step("move-free", [None, reach, None, 1], ["q1", "t0", "q2", "r1"])

        def record() -> None:
            rel = np.subtract(run.object_xy("bowl"), BOWL_AT)
            off_line[0] = abs(rel[0] * direction[1] - rel[1] * direction[0])

        run.probe = record
        run.run_step("push", ["bowl", BOWL_AT, FAR_GOAL, None, None, push, 1],
                     ["bowl", "p0", "p1", "q2", "q3", "t1", "r1"])
        return run.log[-1], off_line[0]
    finally:
        run.close()


@pytest.mark.slow
@pytest.mark.parametrize("run_class", _kitchen_runs(), ids=lambda c: c.__name__)
def test_a_long_push_keeps_the_bowl_on_its_line(run_class: type) -> None:
    entry, off_line = _push(run_class)
    assert entry["finger_gap_m"] == skill_paths.PUSH_FINGER_GAP_M
    assert entry["error_m"] <= PUSH_TOLERANCE_M
    assert off_line < 0.01
    moved = np.hypot(entry["rest_xy"][0] - BOWL_AT[0], entry["rest_xy"][1] - BOWL_AT[1])
    assert moved > 0.6


@pytest.mark.slow
def test_open_fingers_bring_an_off_centre_bowl_back_to_the_line() -> None:
    """The bowl stands 1 cm off the planned line (as an executed plan leaves objects a few
    millimetres from their planned poses): the open fingers centre it between them and
    deliver it. (With the fingers closed the same push ended 0.028 m from the target, just
    inside the 0.03 m tolerance, on a loaded machine; main's closed push_to_reach seed 1
    ended 0.187 m off: ``docs/results/exec3d/push_to_reach_seed1_diag.json``.)"""
    entry, off_line = _push(Kitchen3DRun, offset=0.01)
    assert entry["finger_gap_m"] == skill_paths.PUSH_FINGER_GAP_M
    assert entry["error_m"] <= PUSH_TOLERANCE_M
    assert off_line < 0.005
