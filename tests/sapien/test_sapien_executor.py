"""Replaying kitchen3d plans in SAPIEN: the arm mirror and pour_blocked (rendering: see
test_sapien_replay*.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet as p
import pytest
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

pytest.importorskip("sapien")

from ltamp_cli.backends.execution import load_executor
from ltamp_cli.backends.pybullet.robot.scene import build_kitchen_scene
from ltamp_cli.backends.pybullet.world import PhysicsWorld
from ltamp_cli.backends.sapien.executor import SapienArm, SapienKitchen3DExecutor
from ltamp_cli.backends.sapien.world import SapienWorld
from ltamp_cli.planner.problem import load_problem

ROOT = Path(__file__).resolve().parents[2]
POUR_BLOCKED = ROOT / "problems" / "kitchen3d" / "pour_blocked.yaml"


def _local(pose: object, points: np.ndarray) -> np.ndarray:
    """World points ``(n, 3)`` in the frame of a ``sapien.Pose`` (quaternion wxyz)."""
    w, x, y, z = (float(v) for v in pose.q)  # type: ignore[attr-defined]
    rotation = Rotation.from_quat([x, y, z, w])
    return rotation.inv().apply(points - np.asarray(pose.p, dtype=float))  # type: ignore[attr-defined]


def test_sapien_arm_mirror_matches_the_kinematic_model() -> None:
    """Where a ray hits an arm link in the kinematic model, SAPIEN has that link's surface."""
    model = PhysicsWorld()
    arm = build_kitchen_scene(model.client, 1).arms[0]
    world = SapienWorld()
    mirror = SapienArm(world, arm)
    links = {link: entity for link, _, entity in mirror.links}
    assert set(links) == {-1, 0, 1, 2, 3, 4, 5, 6, 8, 9, 10}
    rng = np.random.default_rng(0)
    compared = 0
    for _ in range(3):
        arm.set_configuration(arm.sample_configuration(rng))
        arm.set_finger_opening(float(rng.uniform(0.0, 0.08)))
        mirror.follow_model()
        world.step()
        hulls = {}
        for link, component, _ in mirror.links:
            shape = component.collision_shapes[0]
            hulls[link] = (shape.local_pose, ConvexHull(shape.get_vertices()).equations)
        starts = rng.uniform([-1.2, -0.8, 0.7], [0.3, 0.8, 1.8], size=(200, 3))
        ends = rng.uniform([-0.8, -0.3, 0.7], [-0.2, 0.3, 1.4], size=(200, 3))
        for hit in p.rayTestBatch(starts.tolist(), ends.tolist(), physicsClientId=model.client):
            if hit[0] != arm.body_id:
                continue
            local_pose, equations = hulls[hit[1]]
            point = _local(local_pose, _local(links[hit[1]].pose, np.array([hit[3]])))[0]
            outside = float((equations[:, :3] @ point + equations[:, 3]).max())
            # On the hull, up to Bullet's ~4 mm collision margin outside it; a misplaced link
            # would put the point centimetres away.
            assert -0.002 < outside < 0.006, (hit[1], outside)
            compared += 1
    assert compared > 100
    model.close()


def test_sapien_backend_provides_the_executor() -> None:
    assert isinstance(load_executor("sapien"), SapienKitchen3DExecutor)


@pytest.mark.slow
def test_pour_blocked_is_solved_and_executed_on_sapien() -> None:
    """pour_blocked's GoodPour controls pass a 30-bead physics pre-check (>= 95 % poured in
    PyBullet), so the pour keeps a margin on SAPIEN too (seeds 0-2: 60/60 beads)."""
    from ltamp_cli.backends.execution import execute_plan
    from ltamp_cli.planner.algorithms.common import PlannerConfig
    from ltamp_cli.planner.api import solve

    problem = load_problem(POUR_BLOCKED)
    result = solve(problem, PlannerConfig(max_time=300, seed=0, max_complexity=40))
    assert result.status == "solved"
    report = execute_plan("sapien", problem, result, seed=0)
    assert report.details["backend"] == "sapien"
    assert report.success, report.details["steps"]
    assert report.goal_holds, report.details["goal"]
    counts = report.details["goal"][0]["counts"]
    assert counts["total"] == 60
    assert counts["bowl"] >= 0.8 * 60
    # A bead or two may bounce off the rim and off the table, as in PyBullet.
    assert counts["off_table"] <= 3
    # The block was really moved out of the way in the simulation.
    places = [entry for entry in report.details["log"] if entry["action"] == "place"]
    assert places and all(entry["error_m"] < 0.02 for entry in places)
    # Deterministic given the seed: a second replay measures the same bead counts.
    again = execute_plan("sapien", problem, result, seed=0)
    assert again.details["goal"] == report.details["goal"]


# Problems whose planning is not reliable within the problem's time limit (xfail, issue 7).
# None now: push_to_reach timed out (seed 1 at 240 s wall) until the kitchen3d test-reach
# stream ruled out each arm's picks/pushes/pours of the far objects before search; seeds 0-2
# now plan in 11/28/11 s CPU (33-62 s wall, load ~4, twice each, same plans), coffee seeds
# 0-2 in 11/20/11 s CPU. Both seed-0 plans hold the goal on PyBullet and SAPIEN.
_KNOWN_PLANNING_GAPS: set[str] = set()


@pytest.mark.slow
@pytest.mark.parametrize(
    "problem_file",
    [pytest.param(name, marks=pytest.mark.xfail(
        strict=False, reason="planning may exceed its time limit under load, issue 7"))
     if name in _KNOWN_PLANNING_GAPS else name
     for name in sorted(p.name for p in POUR_BLOCKED.parent.glob("*.yaml")
                        if p != POUR_BLOCKED)],
)
def test_other_kitchen3d_problems_run_on_sapien_unchanged(problem_file: str) -> None:
    """Every kitchen3d problem executes on SAPIEN, with PyBullet's physical goal verdict."""
    from ltamp_cli.backends.execution import execute_plan
    from ltamp_cli.planner.algorithms.common import PlannerConfig
    from ltamp_cli.planner.api import solve

    problem = load_problem(POUR_BLOCKED.parent / problem_file)
    result = solve(problem, PlannerConfig(**{**problem.planner_options, "seed": 0}))
    assert result.solved, result.status
    ours = execute_plan("sapien", problem, result, seed=0)
    theirs = execute_plan("pybullet", problem, result, seed=0)
    assert ours.success, ours.details["steps"]
    assert ours.goal_holds == theirs.goal_holds, (ours.details["goal"], theirs.details["goal"])
