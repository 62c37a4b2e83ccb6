"""Franka Panda arms for the PyBullet Kitchen3D: kinematics, IK, collisions, Cartesian paths.

Modules: :mod:`.arm` (load the Panda, configurations, FK, gripper), :mod:`.ik` (verified IK
with restarts), :mod:`.collision` (configuration checker with attached bodies and the
carried-tool tilt limit), :mod:`.cartesian` (tool-path following), :mod:`.grasps` (cylinder
grasps), :mod:`.scene` (table with one or two arms), :mod:`.pose` (rigid transforms).
Free-space motion planning lives in :mod:`ltamp_cli.motion` (backend independent); see
:func:`plan_arm_motion` for the Panda-specific wrapper.
"""

from ltamp_cli.backends.pybullet.robot.arm import (
    PANDA_EE_LINK,
    PANDA_HOME,
    PandaArm,
)
from ltamp_cli.backends.pybullet.robot.cartesian import (
    CartesianConfig,
    CartesianPath,
    densify_tool_path,
    follow_tool_path,
)
from ltamp_cli.backends.pybullet.robot.collision import (
    CARRY_TILT_LIMIT,
    ArmCollisionChecker,
    AttachedBody,
    attach_fixed_constraint,
    within_tilt,
)
from ltamp_cli.backends.pybullet.robot.grasps import (
    Grasp,
    cylinder_side_grasps,
    cylinder_top_grasps,
)
from ltamp_cli.backends.pybullet.robot.ik import IKConfig, solve_ik
from ltamp_cli.backends.pybullet.robot.motion import plan_arm_motion
from ltamp_cli.backends.pybullet.robot.pose import Pose
from ltamp_cli.backends.pybullet.robot.scene import (
    KitchenScene,
    TableSpec,
    add_box,
    add_cylinder,
    build_kitchen_scene,
)

__all__ = [
    "CARRY_TILT_LIMIT",
    "PANDA_EE_LINK",
    "PANDA_HOME",
    "ArmCollisionChecker",
    "AttachedBody",
    "CartesianConfig",
    "CartesianPath",
    "Grasp",
    "IKConfig",
    "KitchenScene",
    "PandaArm",
    "Pose",
    "TableSpec",
    "add_box",
    "add_cylinder",
    "attach_fixed_constraint",
    "build_kitchen_scene",
    "cylinder_side_grasps",
    "cylinder_top_grasps",
    "densify_tool_path",
    "follow_tool_path",
    "plan_arm_motion",
    "solve_ik",
    "within_tilt",
]
