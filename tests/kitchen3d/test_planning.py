"""Kitchen3D planning: scene parsing, the obstruction that makes pour_blocked a TAMP problem,
dense collision re-checks of planned motions, and pour_blocked planned and executed with the
goal verified from bead positions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.backends.pybullet.robot.arm import PANDA_HOME
from ltamp_cli.backends.pybullet.robot.pose import Pose
from ltamp_cli.backends.pybullet.tamp.planning import PlanningWorld
from ltamp_cli.backends.pybullet.tamp.scene import scene_from_world
from ltamp_cli.backends.pybullet.tamp.values import ArmConf
from ltamp_cli.errors import InputError
from ltamp_cli.motion.interpolation import densify_path
from ltamp_cli.planner.problem import load_problem

ROOT = Path(__file__).resolve().parents[2]
POUR_BLOCKED = ROOT / "problems" / "kitchen3d" / "pour_blocked.yaml"
CUP_XY, BLOCK_XY = (0.0, 0.15), (-0.068, 0.15)


@pytest.fixture(scope="module")
def problem():  # type: ignore[no-untyped-def]
    return load_problem(POUR_BLOCKED)


@pytest.fixture(scope="module")
def world(problem):  # type: ignore[no-untyped-def]
    planning = PlanningWorld(scene_from_world(problem.world))
    yield planning
    planning.close()


@pytest.mark.parametrize(("world_", "message"), [
    ({"objects": {"cup": {"kind": "mug"}}}, "world.objects.cup.kind"),
    ({"objects": {"cup": {"kind": "cup", "height": 0.1, "top_diameter": 0.07}}},
     "needs 'base_diameter'"),
    ({"objects": {"bowl": {"kind": "bowl", "height": 0.07, "top_diameter": 0.2,
                           "base_diameter": 0.12, "fixed": True}}}, "needs 'at"),
    ({"objects": {"b": {"kind": "block", "size": [0.1, 0.1]}}}, "world.objects.b.size"),
    ({"objects": {"b": {"kind": "block", "size": [0.1, 0.1, 0.1]}}, "arms": 3}, "world.arms"),
    ({"objects": {"b": {"kind": "block", "size": [0.1, 0.1, 0.1]}},
      "regions": {"t": [[0.3, 0.1], [0, 1]]}}, "world.regions.t"),
])
def test_bad_world_names_the_field(world_, message) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InputError, match=message):
        scene_from_world(world_)


def test_block_obstructs_every_reachable_cup_grasp(world) -> None:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(0)
    reachable, freed = 0, 0
    for grasp in world.grasp_values("cup"):
        for _conf, approach in world.pick_kinematics("cup", CUP_XY, grasp, rng):
            reachable += 1
            assert world.path_collides(approach, "block", BLOCK_XY)
            # Moved away (not every spot clears every elbow), the block frees some approach.
            freed += not world.path_collides(approach, "block", (0.15, -0.02))
    assert reachable >= 2
    assert freed >= 1
    # The block itself can be picked from where it stands without touching the cup.
    block_picks = [approach for g in world.grasp_values("block")
                   for _c, approach in world.pick_kinematics("block", BLOCK_XY, g, rng)]
    assert block_picks
    assert not world.path_collides(block_picks[0], "cup", CUP_XY)


def test_planned_motion_is_collision_free_when_rechecked_densely(world) -> None:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(1)
    grasp = world.grasp_values("block")[0]
    conf, _approach = next(world.pick_kinematics("block", BLOCK_XY, grasp, rng))
    home = ArmConf.of(0, np.asarray(PANDA_HOME))
    path = world.plan_motion(home, conf, None, seed=3)
    assert path is not None
    np.testing.assert_allclose(path.configurations[0], home.array, atol=1e-6)
    np.testing.assert_allclose(path.configurations[-1], conf.array, atol=1e-6)
    checker = world.checker(0)
    dense = densify_path(path.configurations, 0.005)
    assert all(checker(q) for q in dense)


@pytest.mark.slow
def test_pour_blocked_is_planned_and_executed_with_beads_in_the_bowl(problem) -> None:  # type: ignore[no-untyped-def]
    from ltamp_cli.backends.execution import execute_plan
    from ltamp_cli.planner.algorithms.common import PlannerConfig
    from ltamp_cli.planner.api import solve

    result = solve(problem, PlannerConfig(max_time=120, seed=0, max_complexity=40))
    assert result.status == "solved"
    names = [step.name for step in result.plan]
    # The block must be moved before the cup can be picked, and the plan ends pouring.
    assert names.index("place") < max(i for i, n in enumerate(names) if n == "pick")
    assert names[-1] == "pour"
    # Moved once, directly: no place-pick-place detour through an intermediate placement.
    assert names == ["move-free", "pick", "move-holding", "place",
                     "move-free", "pick", "move-holding", "pour"]
    assert [step.args[0] for step in result.plan if step.name == "pick"] == ["block", "cup"]
    report = execute_plan("pybullet", problem, result, seed=0)
    assert report.success, report.details["steps"]
    assert report.goal_holds, report.details["goal"]
    counts = report.details["goal"][0]["counts"]
    # Particle conservation: every bead is somewhere (bowl, cup or elsewhere), none vanished
    # through the table, and most are in the bowl.
    assert counts["total"] == 60
    assert counts["bowl"] >= 0.8 * 60


def test_a_push_approach_must_come_down_behind_the_object_not_on_it() -> None:
    """push_to_reach's bowl: the stream's push comes down behind the rim (clear); a hand
    coming down onto the rim collides before its contact pose."""
    import math

    from ltamp_cli.backends.pybullet.tamp import skill_paths

    spec = scene_from_world(load_problem(ROOT / "problems/kitchen3d/push_to_reach.yaml").world)
    planning = PlanningWorld(spec)
    try:
        start, goal = (0.45, 0.3), (0.1, 0.2)
        rng = np.random.default_rng(0)
        heading = math.atan2(goal[1] - start[1], goal[0] - start[0])
        yaw = heading + math.pi / 2
        bowl = spec.objects["bowl"]
        poses = skill_paths.push_hand_poses(bowl, start, goal, planning.table_z, yaw)
        path = planning.follow_hand_path(poses, 1, rng, "push", touching="bowl")
        assert path is not None
        assert not planning.approach_collides(path, "bowl", start, poses[1])
        # The same push planned as if the bowl were 8 cm narrower: the hand comes down on
        # the rim of the real bowl.
        behind_rim = start[0] + 0.1 + skill_paths.FINGER_HALF_M + skill_paths.PUSH_GAP_M - 0.08
        direction = np.subtract(goal, start) / np.linalg.norm(np.subtract(goal, start))
        down = [Pose(np.array([start[0] - direction[0] * (behind_rim - start[0]),
                               start[1] - direction[1] * (behind_rim - start[0]), z]))
                @ Pose.from_euler(np.zeros(3), yaw=yaw)
                @ Pose.from_euler(np.zeros(3), roll=math.pi)
                for z in (planning.table_z + 0.135, planning.table_z + 0.035)]
        onto = planning.follow_hand_path(down, 1, rng, "push", touching="bowl")
        assert onto is not None
        assert planning.approach_collides(onto, "bowl", start, down[1])
    finally:
        planning.close()
