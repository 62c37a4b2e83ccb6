"""Acceleration-limited, rest-to-rest time parameterisation of piecewise-linear paths.

A real arm (or a force-controlled gripper) cannot change its speed instantly: bounding only
the speed of a motion makes its corners jerk whatever it carries (a constant-speed carry in
Kitchen2D started and stopped at ~5 g). Here every straight segment of a path is traversed
with a trapezoidal speed profile (a triangle when the segment is too short to reach the
speed limit) that starts and ends at rest, so the motion stops at every path corner.

Limits apply to groups of coordinates: the Euclidean norm of each group's velocity and
acceleration stays below the group's limit (e.g. ``((0, 1), (2,))`` bounds the planar speed
of ``(x, y)`` and the angular speed of ``θ`` separately; the default, one group per
coordinate, bounds every joint on its own). Sampled at the physics step ``dt``, the returned
positions' second differences divided by ``dt²`` (the accelerations a position-tracking
controller commands) never exceed the limits either: each segment's duration is rounded up
to whole steps by slowing the profile down, never by shortening a step.

Units are the caller's: positions in path units (world units, radians), speeds per second,
accelerations per second squared, ``dt`` in seconds.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

Groups = tuple[tuple[int, ...], ...]


@dataclass(frozen=True)
class MotionLimits:
    """Speed and acceleration limits, one per group of coordinates.

    ``groups[i]`` lists the coordinates whose velocity (acceleration) vector's Euclidean
    norm ``speeds[i]`` (``accelerations[i]``) bounds. ``None`` groups: one group per
    coordinate, and a single speed/acceleration then applies to every coordinate.
    """

    speeds: tuple[float, ...]
    accelerations: tuple[float, ...]
    groups: Groups | None = None

    def __post_init__(self) -> None:
        if len(self.speeds) != len(self.accelerations):
            raise ValueError("one speed and one acceleration per group")
        if any(v <= 0 for v in self.speeds) or any(a <= 0 for a in self.accelerations):
            raise ValueError("speed and acceleration limits must be positive")
        if self.groups is not None and len(self.groups) != len(self.speeds):
            raise ValueError("one speed and one acceleration per group")

    def resolved(self, dof: int) -> tuple[Groups, np.ndarray, np.ndarray]:
        """Groups, speeds ``(g,)`` and accelerations ``(g,)`` for a ``dof``-dimensional path."""
        if self.groups is None:
            if len(self.speeds) == 1:
                return (tuple((i,) for i in range(dof)), np.full(dof, self.speeds[0]),
                        np.full(dof, self.accelerations[0]))
            if len(self.speeds) != dof:
                raise ValueError(f"{len(self.speeds)} limits for a {dof}-dof path")
            groups: Groups = tuple((i,) for i in range(dof))
        else:
            groups = self.groups
            covered = sorted(i for group in groups for i in group)
            if covered != list(range(dof)):
                raise ValueError(f"groups {groups} must cover coordinates 0..{dof - 1} once")
        return groups, np.asarray(self.speeds, float), np.asarray(self.accelerations, float)


def planar_limits(speed: float, angular_speed: float, acceleration: float,
                  angular_acceleration: float) -> MotionLimits:
    """Limits of a planar pose ``(x, y, θ)``: translation ``(x, y)`` and rotation ``θ``."""
    return MotionLimits((speed, angular_speed), (acceleration, angular_acceleration),
                        ((0, 1), (2,)))


def trapezoid_duration(length: float, speed: float, acceleration: float) -> float:
    """Time (s) to travel ``length`` from rest to rest with the given limits."""
    if length <= 0:
        return 0.0
    peak = min(speed, math.sqrt(acceleration * length))
    return length / peak + peak / acceleration


def trapezoid_fraction(times: np.ndarray, length: float, speed: float,
                       acceleration: float) -> np.ndarray:
    """Fraction in ``[0, 1]`` of ``length`` travelled at ``times`` (s), shape of ``times``."""
    if length <= 0:
        return np.ones_like(np.asarray(times, dtype=float))
    t = np.asarray(times, dtype=float)
    peak = min(speed, math.sqrt(acceleration * length))
    ramp = peak / acceleration
    cruise = length / peak - ramp
    down = np.clip(t - ramp - cruise, 0.0, ramp)
    s = (0.5 * acceleration * np.minimum(t, ramp) ** 2
         + peak * np.clip(t - ramp, 0.0, cruise)
         + peak * down - 0.5 * acceleration * down ** 2)
    return np.clip(s / length, 0.0, 1.0)


def min_jerk(length: float, speed: float, accel: float, dt: float) -> np.ndarray:
    """Rest-to-rest minimum-jerk progress along a straight leg of ``length`` units (a smoother
    alternative to the trapezoid: its acceleration is continuous; the 2D pour's carry uses it).

    s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ peaks at 1.875·L/T in speed and 5.774·L/T² in acceleration,
    so the duration T is the shortest meeting both limits. Returns the fractions of the
    leg reached at the end of each ``dt`` step, shape ``(steps,)``, ending at 1.0.
    """
    if length <= 0.0:
        return np.zeros(0)
    duration = max(1.875 * length / speed, math.sqrt(5.7735 * length / accel))
    tau = np.arange(1, math.ceil(duration / dt - 1e-9) + 1) * dt / duration
    tau = np.minimum(tau, 1.0)
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


def segment_limits(delta: np.ndarray, groups: Groups, speeds: np.ndarray,
                   accelerations: np.ndarray) -> tuple[float, float]:
    """Limits on the path parameter's speed and acceleration (per second, per second²) of a
    straight segment ``delta`` ``(dof,)``, parameter 0 at its start and 1 at its end."""
    speed = acceleration = math.inf
    for group, v, a in zip(groups, speeds, accelerations, strict=True):
        extent = float(np.linalg.norm(delta[list(group)]))
        if extent > 0:
            speed = min(speed, v / extent)
            acceleration = min(acceleration, a / extent)
    return speed, acceleration


def time_segment(start: np.ndarray, end: np.ndarray, limits: MotionLimits,
                 dt: float) -> np.ndarray:
    """Positions one step ``dt`` apart after ``start`` up to ``end`` (included), rest to rest.

    Shape ``(m, dof)``, ``m >= 1``; empty ``(0, dof)`` when ``start == end``.
    """
    q0, q1 = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    delta = q1 - q0
    if not np.any(np.abs(delta) > 1e-12):
        return np.zeros((0, q0.size))
    groups, speeds, accelerations = limits.resolved(q0.size)
    speed, acceleration = segment_limits(delta, groups, speeds, accelerations)
    duration = trapezoid_duration(1.0, speed, acceleration)
    steps = max(1, math.ceil(duration / dt - 1e-9))
    # Stretching the profile by ``stretch >= 1`` divides its speeds by ``stretch`` and its
    # accelerations by ``stretch²``: whole steps never break the limits.
    stretch = steps * dt / duration
    times = np.arange(1, steps + 1) * dt / stretch
    fractions = trapezoid_fraction(times, 1.0, speed, acceleration)
    fractions[-1] = 1.0
    return q0[None, :] + fractions[:, None] * delta[None, :]


def time_path(path: Sequence[Sequence[float]] | np.ndarray, limits: MotionLimits,
              dt: float) -> np.ndarray:
    """Positions one step ``dt`` apart along ``path`` ``(n, dof)``, stopping at every corner.

    Returns shape ``(m, dof)``: the first row is ``path[0]`` (the current position, not a
    command), then one row per physics step; the last row is ``path[-1]``. Repeated
    waypoints are skipped.
    """
    points = np.asarray(path, dtype=float)
    if points.ndim != 2 or points.shape[0] == 0:
        raise ValueError(f"a path must have shape (n_waypoints, dof), n >= 1; got {points.shape}")
    if dt <= 0:
        raise ValueError("dt must be positive")
    pieces = [points[:1]]
    for q0, q1 in itertools.pairwise(points):
        pieces.append(time_segment(q0, q1, limits, dt))
    return np.concatenate(pieces, axis=0)


def peak_rates(positions: np.ndarray, dt: float,
               groups: Groups | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Largest speed and acceleration of each group along sampled ``positions`` ``(m, dof)``,
    by finite differences (first and second differences over ``dt``), assuming rest before
    the first and after the last sample. Returns two arrays of shape ``(g,)``."""
    q = np.asarray(positions, dtype=float)
    padded = np.concatenate([q[:1], q, q[-1:]], axis=0)
    velocity = np.diff(padded, axis=0) / dt
    acceleration = np.diff(velocity, axis=0) / dt
    if groups is None:
        groups = tuple((i,) for i in range(q.shape[1]))
    speeds = np.array([np.linalg.norm(velocity[:, list(g)], axis=1).max() for g in groups])
    accels = np.array([np.linalg.norm(acceleration[:, list(g)], axis=1).max() for g in groups])
    return speeds, accels
