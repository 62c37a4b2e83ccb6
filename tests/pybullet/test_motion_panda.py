"""RRT-Connect for the Panda with pybullet collision checks, re-checked densely."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pybullet
import pytest

from ltamp_cli.backends.pybullet.robot import (
    ArmCollisionChecker,
    KitchenScene,
    Pose,
    add_box,
    build_kitchen_scene,
    plan_arm_motion,
    solve_ik,
)
from ltamp_cli.backends.pybullet.robot.arm import PANDA_HAND_LINKS
from ltamp_cli.backends.pybullet.robot.collision import (
    PANDA_SELF_COLLISION_PAIRS,
    AttachedBody,
    sample_self_collision_pairs,
)
from ltamp_cli.motion import RRTConnectConfig, densify_path, is_path_valid


@pytest.fixture(scope="module")
def scene_with_wall() -> Iterator[tuple[KitchenScene, int]]:
    client = pybullet.connect(pybullet.DIRECT)
    try:
        scene = build_kitchen_scene(client, n_arms=1)
        wall = add_box(
            client, (0.03, 0.2, 0.12), Pose(scene.table_centre + np.array([-0.05, 0.0, 0.12]))
        )
        yield scene, wall
    finally:
        pybullet.disconnect(physicsClientId=client)


def _down(scene: KitchenScene, offset: list[float]) -> Pose:
    return Pose.from_euler(scene.table_centre + np.asarray(offset), roll=np.pi)


def _query_across_the_wall(scene_with_wall: tuple[KitchenScene, int]
                           ) -> tuple[Any, ArmCollisionChecker, np.ndarray, np.ndarray]:
    """``(arm, checker, start, goal)``: two IK solutions on either side of the wall."""
    scene, wall = scene_with_wall
    arm = scene.arms[0]
    checker = ArmCollisionChecker(arm, scene.obstacles_for(0, [wall]))
    rng = np.random.default_rng(0)
    start = solve_ik(arm, _down(scene, [-0.2, -0.1, 0.1]), rng, is_valid=checker)
    goal = solve_ik(arm, _down(scene, [0.1, 0.1, 0.1]), rng, is_valid=checker)
    assert start is not None and goal is not None
    return arm, checker, start, goal


def test_plan_around_a_wall_is_collision_free_when_rechecked_densely(
    scene_with_wall: tuple[KitchenScene, int],
) -> None:
    scene, wall = scene_with_wall
    arm, checker, start, goal = _query_across_the_wall(scene_with_wall)
    # The wall matters: the straight joint-space line between them collides.
    assert not is_path_valid(np.stack([start, goal]), checker, 0.01)

    plan = plan_arm_motion(arm, start, goal, checker, RRTConnectConfig(seed=1, time_limit=10.0))
    assert plan.success and plan.path is not None
    assert np.allclose(plan.path[0], start) and np.allclose(plan.path[-1], goal)
    # Re-check four times finer than the planner's resolution, with a fresh checker.
    fresh = ArmCollisionChecker(arm, scene.obstacles_for(0, [wall]))
    dense = densify_path(plan.path, 0.005)
    assert all(fresh(q) for q in dense)


def test_checker_detects_table_and_self_collisions(
    scene_with_wall: tuple[KitchenScene, int],
) -> None:
    scene, wall = scene_with_wall
    arm = scene.arms[0]
    checker = ArmCollisionChecker(arm, scene.obstacles_for(0, [wall]))
    assert checker(np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]))
    # Shoulder pitched far forward: the forearm goes through the table top.
    assert not checker(np.array([0.0, 1.7, 0.0, -0.2, 0.0, 1.5, 0.0]))


def test_self_collision_check_matches_brute_force(
    scene_with_wall: tuple[KitchenScene, int],
) -> None:
    scene, _ = scene_with_wall
    arm = scene.arms[0]
    only_self = ArmCollisionChecker(arm, ())
    robot, client = arm.body_id, arm.client_id

    def touching_pairs() -> set[tuple[int, int]]:
        points = pybullet.getClosestPoints(robot, robot, 0.0, physicsClientId=client)
        return {(min(p[3], p[4]), max(p[3], p[4])) for p in points if p[3] != p[4] and p[8] < -1e-4}

    arm.set_configuration(np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]))
    adjacent = touching_pairs()
    rng = np.random.default_rng(5)
    n_colliding = 0
    for _ in range(150):
        q = arm.sample_configuration(rng)
        arm.set_configuration(q)
        colliding = bool(touching_pairs() - adjacent)
        n_colliding += colliding
        assert only_self(q) == (not colliding)
    assert n_colliding >= 5


def test_self_collision_pairs_cover_sampled_contacts(
    scene_with_wall: tuple[KitchenScene, int],
) -> None:
    scene, _ = scene_with_wall
    seen = sample_self_collision_pairs(scene.arms[0], np.random.default_rng(11), 300)
    assert seen, "random configurations do self-collide sometimes"
    assert seen <= set(PANDA_SELF_COLLISION_PAIRS)


def test_a_check_budget_makes_the_search_reproducible_and_bounded(
    scene_with_wall: tuple[KitchenScene, int],
) -> None:
    """With ``max_checks`` a query's outcome depends on its seed, not on wall time: two runs
    give the same path, and a search that cannot succeed stops after its budget."""
    arm, checker, start, goal = _query_across_the_wall(scene_with_wall)
    config = RRTConnectConfig(seed=4, time_limit=60.0, max_checks=20_000)
    first = plan_arm_motion(arm, start, goal, checker, config)
    second = plan_arm_motion(arm, start, goal, checker, config)
    assert first.path is not None and second.path is not None
    np.testing.assert_array_equal(first.path, second.path)
    assert first.n_validity_checks == second.n_validity_checks

    # Nothing but the start is valid here: the search ends on its budget, long before 60 s.
    def only_start(q: np.ndarray) -> bool:
        return bool(np.allclose(q, start) or np.allclose(q, goal))

    blocked = plan_arm_motion(arm, start, goal, only_start,
                              RRTConnectConfig(seed=4, time_limit=60.0, max_checks=500))
    assert blocked.status == "timeout"
    assert 500 <= blocked.n_validity_checks <= 600
    assert blocked.planning_time < 30.0


def test_bounding_box_prefilter_gives_the_brute_force_answers(
    scene_with_wall: tuple[KitchenScene, int],
) -> None:
    """The checker skips ``getClosestPoints`` when bounding boxes are apart; over random
    configurations, with and without a held box, it answers as querying every body does."""
    scene, wall = scene_with_wall
    arm = scene.arms[0]
    client, robot = arm.client_id, arm.body_id
    held = add_box(client, (0.02, 0.02, 0.05), Pose(np.array([5.0, 5.0, 0.0])))
    grasp = Pose(np.array([0.0, 0.0, 0.06]))
    obstacles = scene.obstacles_for(0, [wall])
    rng = np.random.default_rng(8)
    for attached in (None, AttachedBody(held, grasp)):
        checker = ArmCollisionChecker(arm, obstacles, attached)
        answers = []
        for _ in range(300):
            q = arm.sample_configuration(rng)
            valid = checker(q)
            # Brute force: every obstacle queried, whatever the boxes say.
            hit = any(p[3] != -1 and p[8] < -1e-3 for body in obstacles
                      for p in pybullet.getClosestPoints(robot, body, 0.0,
                                                         physicsClientId=client))
            if attached is not None:
                hit = hit or any(p[8] < -1e-3 for body in obstacles for p in
                                 pybullet.getClosestPoints(held, body, 0.0,
                                                           physicsClientId=client))
                hit = hit or any(p[4] not in PANDA_HAND_LINKS and p[8] < -1e-3 for p in
                                 pybullet.getClosestPoints(held, robot, 0.0,
                                                           physicsClientId=client))
            reference = not hit and ArmCollisionChecker(arm, ())(q)
            answers.append(valid)
            assert valid == reference
        assert 0.1 < np.mean(answers) < 0.95  # both verdicts occur


def test_a_free_straight_segment_is_the_motion(
    scene_with_wall: tuple[KitchenScene, int],
) -> None:
    scene, _ = scene_with_wall
    arm = scene.arms[0]
    checker = ArmCollisionChecker(arm, scene.obstacles_for(0))
    start = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    goal = start + np.array([0.4, 0.1, 0.0, 0.1, 0.0, 0.0, 0.3])
    plan = plan_arm_motion(arm, start, goal, checker, RRTConnectConfig(seed=0, max_checks=500))
    assert plan.path is not None and plan.path.shape == (2, 7)
    assert all(checker(q) for q in densify_path(plan.path, 0.01))
    # Without the straight segment first, RRT-Connect finds some other valid path.
    searched = plan_arm_motion(arm, start, goal, checker, RRTConnectConfig(seed=0),
                               straight_first=False)
    assert searched.path is not None
    assert all(checker(q) for q in densify_path(searched.path, 0.01))
