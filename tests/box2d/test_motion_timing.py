"""Acceleration-limited rest-to-rest timing (ltamp_cli.motion.timing)."""

from __future__ import annotations

import numpy as np
import pytest

from ltamp_cli.motion.timing import (
    MotionLimits,
    peak_rates,
    planar_limits,
    time_path,
    trapezoid_duration,
)

DT = 0.01


def test_planar_path_respects_speed_and_acceleration_limits_and_ends_exactly() -> None:
    limits = planar_limits(speed=3.0, angular_speed=1.0, acceleration=5.0,
                           angular_acceleration=2.0)
    path = np.array([[0.0, 0.0, 0.0], [4.0, 3.0, 0.0], [4.0, 3.0, -1.5], [-2.0, 1.0, 0.2]])
    timed = time_path(path, limits, DT)
    assert np.allclose(timed[0], path[0]) and np.allclose(timed[-1], path[-1])
    speeds, accels = peak_rates(timed, DT, ((0, 1), (2,)))
    assert speeds[0] <= 3.0 + 1e-9 and speeds[1] <= 1.0 + 1e-9
    assert accels[0] <= 5.0 + 1e-9 and accels[1] <= 2.0 + 1e-9
    # Long segments reach the speed limit (the profile is not needlessly slow).
    assert speeds[0] > 0.95 * 3.0


def test_path_stops_at_every_corner() -> None:
    limits = planar_limits(4.0, 1.0, 5.0, 2.0)
    path = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [5.0, 5.0, 0.0]])
    timed = time_path(path, limits, DT)
    corner = int(np.argmin(np.linalg.norm(timed - path[1], axis=1)))
    assert np.allclose(timed[corner], path[1])
    before = np.linalg.norm(timed[corner] - timed[corner - 1]) / DT
    after = np.linalg.norm(timed[corner + 1] - timed[corner]) / DT
    # At rest within one step's acceleration: a <= 5 u/s² gives at most 0.5 * 5 * dt.
    assert before <= 0.5 * 5.0 * DT + 1e-9 and after <= 0.5 * 5.0 * DT + 1e-9


def test_constant_speed_motion_would_break_the_limit() -> None:
    # The check can fail: a constant-speed motion (what the executor did before) starts
    # with an acceleration of speed / dt.
    constant = np.linspace(0.0, 5.0, 126)[:, None] * np.array([[1.0, 0.0, 0.0]])
    _, accels = peak_rates(constant, DT, ((0, 1), (2,)))
    assert accels[0] > 100.0


def test_per_joint_limits_and_durations() -> None:
    limits = MotionLimits((1.5,), (2.0,))
    path = np.array([np.zeros(7), np.linspace(-1.0, 1.0, 7), np.zeros(7)])
    timed = time_path(path, limits, 1 / 240)
    speeds, accels = peak_rates(timed, 1 / 240)
    assert speeds.max() <= 1.5 + 1e-9 and accels.max() <= 2.0 + 1e-9
    # Triangle profile: 1 rad at 2 rad/s² takes 2 sqrt(1 / 2) s.
    assert trapezoid_duration(1.0, 1.5, 2.0) == pytest.approx(2 * np.sqrt(0.5))
    expected = 2 * trapezoid_duration(1.0, 1.5, 2.0)
    assert (len(timed) - 1) / 240 == pytest.approx(expected, abs=2 / 240)


def test_bad_limits_and_paths_raise() -> None:
    with pytest.raises(ValueError):
        MotionLimits((1.0,), (0.0,))
    with pytest.raises(ValueError):
        time_path(np.zeros((0, 3)), planar_limits(1, 1, 1, 1), DT)
    with pytest.raises(ValueError):
        time_path(np.eye(2, 3), MotionLimits((1.0, 1.0), (1.0, 1.0), ((0, 1), (1,))), DT)
