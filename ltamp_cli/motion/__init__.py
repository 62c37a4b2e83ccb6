"""Backend-independent motion planning in joint (real-vector) spaces.

Nothing here imports a physics engine: a backend supplies a state-validity callback
``is_valid(q: np.ndarray) -> bool`` and joint bounds, and gets back joint paths of shape
``(n_waypoints, dof)``. Used by the PyBullet, SAPIEN and Box2D backends.
"""

from ltamp_cli.motion.interpolation import (
    densify_path,
    first_invalid_configuration,
    interpolate_configurations,
    is_path_valid,
    path_length,
    shortcut_path,
)
from ltamp_cli.motion.rrt_connect import MotionPlan, RRTConnectConfig, plan_rrt_connect

__all__ = [
    "MotionPlan",
    "RRTConnectConfig",
    "densify_path",
    "first_invalid_configuration",
    "interpolate_configurations",
    "is_path_valid",
    "path_length",
    "plan_rrt_connect",
    "shortcut_path",
]
