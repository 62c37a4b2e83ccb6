"""Free-space motion of a Panda: :func:`ltamp_cli.motion.plan_rrt_connect` in its joint limits."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ltamp_cli.backends.pybullet.robot.arm import PandaArm
from ltamp_cli.motion.rrt_connect import MotionPlan, RRTConnectConfig, plan_rrt_connect


def plan_arm_motion(
    arm: PandaArm,
    start: np.ndarray,
    goal: np.ndarray,
    is_valid: Callable[[np.ndarray], bool],
    config: RRTConnectConfig | None = None,
) -> MotionPlan:
    """RRT-Connect from ``start`` to ``goal`` (shape ``(7,)``) for ``arm``.

    ``is_valid`` is usually an :class:`ArmCollisionChecker` (with a grasped body attached
    and the tilt limit when carrying contents). The arm is left where it was.
    """
    original = arm.get_configuration()
    try:
        return plan_rrt_connect(start, goal, arm.lower_limits, arm.upper_limits, is_valid, config)
    finally:
        arm.set_configuration(original)
