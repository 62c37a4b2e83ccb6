"""Free-space motion of a Panda: :func:`ltamp_cli.motion.plan_rrt_connect` in its joint limits,
after the straight joint-space segment has been tried."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import numpy as np

from ltamp_cli.backends.pybullet.robot.arm import PandaArm
from ltamp_cli.motion.interpolation import interpolate_configurations
from ltamp_cli.motion.rrt_connect import MotionPlan, RRTConnectConfig, plan_rrt_connect


class _MemoValidity:
    """``is_valid`` remembered per configuration for one query (the scene does not change
    during it): the final dense re-check then re-uses the shortcut's and the straight
    segment's checks instead of paying for them again."""

    def __init__(self, is_valid: Callable[[np.ndarray], bool]) -> None:
        self._is_valid = is_valid
        self._known: dict[bytes, bool] = {}
        self.calls = 0
        self.evaluated = 0

    def __call__(self, q: np.ndarray) -> bool:
        self.calls += 1
        key = np.asarray(q, dtype=float).tobytes()
        known = self._known.get(key)
        if known is None:
            self.evaluated += 1
            known = self._known[key] = bool(self._is_valid(q))
        return known


def _coarse_to_fine(n: int) -> list[int]:
    """Indices ``0..n-1``, every 16th first, then every 8th, ... (collisions on a straight
    segment are found after a few checks, not after walking up to them)."""
    order: list[int] = []
    seen: set[int] = set()
    for stride in (16, 8, 4, 2, 1):
        for index in range(0, n, stride):
            if index not in seen:
                seen.add(index)
                order.append(index)
    return order


def straight_segment(start: np.ndarray, goal: np.ndarray,
                     is_valid: Callable[[np.ndarray], bool], resolution: float
                     ) -> np.ndarray | None:
    """``[start, goal]`` (shape ``(2, 7)``) when every configuration of the joint-space
    segment between them, ``resolution`` radians apart, is valid; else None."""
    points = interpolate_configurations(start, goal, resolution)
    if all(is_valid(points[i]) for i in _coarse_to_fine(points.shape[0])):
        return np.stack([np.asarray(start, dtype=float), np.asarray(goal, dtype=float)])
    return None


def plan_arm_motion(
    arm: PandaArm,
    start: np.ndarray,
    goal: np.ndarray,
    is_valid: Callable[[np.ndarray], bool],
    config: RRTConnectConfig | None = None,
    straight_first: bool = True,
) -> MotionPlan:
    """A valid path from ``start`` to ``goal`` (shape ``(7,)``) for ``arm``: the straight
    joint-space segment when it is valid (and ``straight_first``), else RRT-Connect
    (``config``).

    ``is_valid`` is usually an :class:`ArmCollisionChecker` (with a grasped body attached
    and the tilt limit when carrying contents). Checks are remembered per configuration
    for the query. The arm is left where it was.
    """
    settings = config or RRTConnectConfig()
    original = arm.get_configuration()
    memo = _MemoValidity(is_valid)
    began = time.perf_counter()
    try:
        q_start, q_goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
        inside = all(np.all(q >= arm.lower_limits) and np.all(q <= arm.upper_limits)
                     for q in (q_start, q_goal))
        # Many kitchen motions (lifting, short transfers) are straight in joint space: a
        # segment costs ~|dq|/resolution checks, an RRT query with shortcutting many more.
        direct = (straight_segment(q_start, q_goal, memo, settings.resolution)
                  if inside and straight_first else None)
        if direct is not None:
            return MotionPlan(direct, "solved", time.perf_counter() - began, memo.calls)
        plan = plan_rrt_connect(start, goal, arm.lower_limits, arm.upper_limits, memo, settings)
        return dataclasses.replace(plan, planning_time=time.perf_counter() - began,
                                   n_validity_checks=memo.calls)
    finally:
        arm.set_configuration(original)
