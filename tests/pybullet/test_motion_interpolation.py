"""Backend-independent motion tools on a 2-D toy space (real OMPL, no physics)."""

from __future__ import annotations

import time

import numpy as np
import pytest

from ltamp_cli.motion import (
    RRTConnectConfig,
    densify_path,
    first_invalid_configuration,
    interpolate_configurations,
    is_path_valid,
    path_length,
    plan_rrt_connect,
    shortcut_path,
)

LOWS = -np.ones(2)
HIGHS = np.ones(2)


def wall_free(q: np.ndarray) -> bool:
    """A wall at |x| < 0.2 from y = -0.8 upwards: paths must dip below it."""
    return not (abs(q[0]) < 0.2 and q[1] > -0.8)


def test_interpolation_respects_resolution_and_endpoints() -> None:
    q_from, q_to = np.array([0.0, 0.0, 1.0]), np.array([1.0, -0.5, 1.0])
    segment = interpolate_configurations(q_from, q_to, 0.1)
    assert np.allclose(segment[0], q_from) and np.allclose(segment[-1], q_to)
    assert np.max(np.abs(np.diff(segment, axis=0))) <= 0.1 + 1e-12
    assert segment.shape == (11, 3)


def test_densify_keeps_waypoints_and_step_bound() -> None:
    path = np.array([[0.0, 0.0], [0.5, 0.0], [0.5, 0.7]])
    dense = densify_path(path, 0.05)
    assert np.max(np.abs(np.diff(dense, axis=0))) <= 0.05 + 1e-12
    for waypoint in path:
        assert np.min(np.linalg.norm(dense - waypoint, axis=1)) < 1e-12
    assert path_length(dense) == pytest.approx(path_length(path))


def test_dense_check_finds_a_thin_obstacle_between_waypoints() -> None:
    path = np.array([[-0.5, 0.5], [0.5, 0.5]])
    assert first_invalid_configuration(path, wall_free, 0.05) is not None
    assert is_path_valid(np.array([[-0.5, 0.5], [-0.5, -0.9]]), wall_free, 0.05)


def test_rrt_connect_plans_around_the_wall_and_is_deterministic() -> None:
    start, goal = np.array([-0.5, 0.5]), np.array([0.5, 0.5])
    config = RRTConnectConfig(seed=3, resolution=0.01)
    first = plan_rrt_connect(start, goal, LOWS, HIGHS, wall_free, config)
    second = plan_rrt_connect(start, goal, LOWS, HIGHS, wall_free, config)
    assert first.success and first.status == "solved"
    assert first.path is not None and second.path is not None
    assert np.array_equal(first.path, second.path)
    assert np.allclose(first.path[0], start) and np.allclose(first.path[-1], goal)
    assert is_path_valid(first.path, wall_free, 0.01)
    # It must go below the wall, so it is much longer than the straight line.
    assert path_length(first.path) > 2.5


def test_rrt_connect_reports_invalid_endpoints_and_unreachable_goals() -> None:
    inside_wall = plan_rrt_connect(
        np.array([0.0, 0.5]), np.array([0.5, 0.5]), LOWS, HIGHS, wall_free
    )
    assert not inside_wall.success and inside_wall.status == "start invalid"

    def sealed(q: np.ndarray) -> bool:
        return abs(q[0]) >= 0.2

    unreachable = plan_rrt_connect(
        np.array([-0.5, 0.5]),
        np.array([0.5, 0.5]),
        LOWS,
        HIGHS,
        sealed,
        RRTConnectConfig(time_limit=0.2),
    )
    assert not unreachable.success and unreachable.status == "timeout"


def test_validity_errors_propagate_out_of_ompl() -> None:
    calls = {"n": 0}

    def flaky(q: np.ndarray) -> bool:
        calls["n"] += 1
        if calls["n"] > 5:
            raise RuntimeError("checker broke")
        return wall_free(q)

    with pytest.raises(RuntimeError, match="checker broke"):
        plan_rrt_connect(np.array([-0.5, 0.5]), np.array([0.5, 0.5]), LOWS, HIGHS, flaky)


def test_shortcutting_never_lengthens_and_stays_valid() -> None:
    rng = np.random.default_rng(0)
    detour = np.array(
        [[-0.5, 0.5], [-0.9, -0.2], [-0.4, -0.95], [0.4, -0.95], [0.9, -0.2], [0.5, 0.5]]
    )
    assert is_path_valid(detour, wall_free, 0.01)
    short = shortcut_path(detour, wall_free, 0.01, rng, iterations=200)
    assert path_length(short) < path_length(detour) - 0.1
    assert np.allclose(short[0], detour[0]) and np.allclose(short[-1], detour[-1])
    assert is_path_valid(short, wall_free, 0.01)


def test_a_check_budget_is_not_cut_short_by_a_loaded_machine() -> None:
    """With ``max_checks`` the time limit caps CPU time, not wall time: checks that take
    wall time without CPU (a machine busy with other work; here a 0.5 ms sleep each) still
    get their whole budget, so which queries succeed depends on the seed, not the load.
    The query needs ~2,600 checks (~1.3 s of wall, ~0.15 s of CPU); a wall cap of 0.5 s
    stopped it after ~1,000."""
    def slow_wall_free(q: np.ndarray) -> bool:
        time.sleep(0.0005)
        return wall_free(q)

    plan = plan_rrt_connect(np.array([-0.5, 0.5]), np.array([0.5, 0.5]), LOWS, HIGHS,
                            slow_wall_free,
                            RRTConnectConfig(time_limit=0.5, seed=0, max_checks=5000,
                                             shortcut_iterations=0))
    assert plan.success, plan.status
    assert plan.planning_time > 0.5  # it ran past the wall time the limit names
