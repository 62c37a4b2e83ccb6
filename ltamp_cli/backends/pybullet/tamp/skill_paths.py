"""Learned-skill tool paths placed in the kitchen: the skill-frame path of a control, turned
and moved onto the target object standing on the table.

The skills are symmetric about the target's vertical axis (revolved bowls) and about the
tool's own axis (revolved cups), so a skill path may be turned by ``ψ`` about the target and
the tool by ``φ`` about its axis without changing the physics the skill model learned.
"""

from __future__ import annotations

import numpy as np

from ltamp_cli.backends.pybullet.robot.pose import Pose
from ltamp_cli.backends.pybullet.skills.pour import PourContext, pour_path
from ltamp_cli.backends.pybullet.tamp.planning import pose_of
from ltamp_cli.backends.pybullet.tamp.scene import XY, ObjectSpec


def pour_context(cup: ObjectSpec, bowl: ObjectSpec) -> np.ndarray:
    """The GoodPour context ``(6,)`` of pouring ``cup`` into ``bowl`` (skill order)."""
    return PourContext(bowl.vessel(), cup.vessel()).to_array()


def pour_tool_poses(cup: ObjectSpec, bowl: ObjectSpec, bowl_xy: XY, table_z: float,
                    control: np.ndarray, psi: float, phi: float) -> list[Pose]:
    """World poses of the cup's base frame along the pour of ``control`` (5,)."""
    path = pour_path(PourContext(bowl.vessel(), cup.vessel()), np.asarray(control, dtype=float))
    frame = pose_of(bowl_xy, table_z, yaw=psi)
    spin = Pose.from_euler(np.zeros(3), yaw=phi)
    return [frame @ Pose(position, quaternion) @ spin
            for position, quaternion in zip(path.positions, path.quaternions, strict=True)]
