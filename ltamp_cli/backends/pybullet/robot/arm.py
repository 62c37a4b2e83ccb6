"""The Franka Panda from ``pybullet_data``: loading, joint limits, configurations, FK, gripper.

Every pybullet call passes ``physicsClientId``; the implicit default client is never used.
Methods that take a configuration *move the arm kinematically* in its client
(``resetJointState``, no simulation step), which is how planners query FK and collisions.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np
import pybullet
import pybullet_data

from ltamp_cli.backends.pybullet.robot.pose import Pose

PANDA_URDF = "franka_panda/panda.urdf"
PANDA_ARM_JOINTS: tuple[int, ...] = (0, 1, 2, 3, 4, 5, 6)
PANDA_FINGER_JOINTS: tuple[int, ...] = (9, 10)
PANDA_EE_LINK = 11
"""``panda_grasptarget``: the point between the finger pads, z axis out of the palm,
fingers closing along its y axis."""
PANDA_HAND_LINK = 8
PANDA_HAND_LINKS: tuple[int, ...] = (8, 9, 10)
"""Links with collision geometry that touch a grasped object (hand, two fingers)."""
PANDA_FINGER_TRAVEL = 0.04
"""Each finger's prismatic range in metres; the gripper opens to at most 0.08 m."""
PANDA_HOME: tuple[float, ...] = (0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785)
"""A tucked, collision-free configuration (radians), gripper pointing down."""


class PandaArm:
    """One fixed-base Panda in a pybullet client.

    ``base_pose`` places ``panda_link0`` in the world (metres, quaternion xyzw). The arm's
    configuration ``q`` has shape ``(7,)`` in radians (joints ``panda_joint1..7``).
    """

    dof = len(PANDA_ARM_JOINTS)

    def __init__(self, client_id: int, base_pose: Pose | None = None) -> None:
        self.client_id = int(client_id)
        self.base_pose = base_pose or Pose()
        position, quaternion = self.base_pose.as_tuples()
        self.body_id = pybullet.loadURDF(
            os.path.join(pybullet_data.getDataPath(), PANDA_URDF),
            basePosition=position,
            baseOrientation=quaternion,
            useFixedBase=True,
            physicsClientId=self.client_id,
        )
        lows, highs = [], []
        for joint in PANDA_ARM_JOINTS:
            info = pybullet.getJointInfo(self.body_id, joint, physicsClientId=self.client_id)
            lows.append(info[8])
            highs.append(info[9])
        self.lower_limits = np.asarray(lows, dtype=float)
        self.upper_limits = np.asarray(highs, dtype=float)
        self.set_configuration(np.asarray(PANDA_HOME))
        self.set_finger_opening(2 * PANDA_FINGER_TRAVEL)

    # Configurations ----------------------------------------------------------------------

    def within_limits(self, q: np.ndarray, tolerance: float = 1e-9) -> bool:
        """True when every joint of ``q`` (shape ``(7,)``) lies inside its limits."""
        array = np.asarray(q, dtype=float)
        return bool(
            np.all(array >= self.lower_limits - tolerance)
            and np.all(array <= self.upper_limits + tolerance)
        )

    def sample_configuration(self, rng: np.random.Generator) -> np.ndarray:
        """A uniform random configuration inside the joint limits, shape ``(7,)``."""
        return rng.uniform(self.lower_limits, self.upper_limits)

    def set_configuration(self, q: np.ndarray) -> None:
        """Reset the seven arm joints to ``q`` (radians) with zero velocity."""
        values = np.asarray(q, dtype=float)
        if values.shape != (self.dof,):
            raise ValueError(f"a Panda configuration has shape (7,), got {values.shape}")
        # One multi-DoF call is ~5x faster than seven resetJointState calls.
        pybullet.resetJointStatesMultiDof(
            self.body_id,
            PANDA_ARM_JOINTS,
            [[float(value)] for value in values],
            physicsClientId=self.client_id,
        )

    def get_configuration(self) -> np.ndarray:
        """The arm joints' current positions, shape ``(7,)`` radians."""
        states = pybullet.getJointStates(
            self.body_id, PANDA_ARM_JOINTS, physicsClientId=self.client_id
        )
        return np.array([state[0] for state in states], dtype=float)

    # Kinematics --------------------------------------------------------------------------

    def end_effector_pose(self) -> Pose:
        """World pose of the grasp target (link 11) at the current configuration."""
        state = pybullet.getLinkState(
            self.body_id,
            PANDA_EE_LINK,
            computeForwardKinematics=True,
            physicsClientId=self.client_id,
        )
        return Pose(np.asarray(state[4]), np.asarray(state[5]))

    def forward_kinematics(self, q: np.ndarray) -> Pose:
        """World pose of the grasp target at ``q``; leaves the arm at ``q``."""
        self.set_configuration(q)
        return self.end_effector_pose()

    # Gripper -----------------------------------------------------------------------------

    def set_finger_opening(self, width: float) -> None:
        """Kinematically set the gap between the fingers (metres, clipped to [0, 0.08])."""
        per_finger = float(np.clip(width / 2.0, 0.0, PANDA_FINGER_TRAVEL))
        for joint in PANDA_FINGER_JOINTS:
            pybullet.resetJointState(
                self.body_id, joint, per_finger, physicsClientId=self.client_id
            )

    def finger_opening(self) -> float:
        """Current gap between the fingers in metres."""
        states = pybullet.getJointStates(
            self.body_id, PANDA_FINGER_JOINTS, physicsClientId=self.client_id
        )
        return float(sum(state[0] for state in states))

    def open_gripper(self) -> None:
        self.set_finger_opening(2 * PANDA_FINGER_TRAVEL)

    def close_gripper(self, width: float = 0.0) -> None:
        """Close the fingers kinematically down to ``width`` (e.g. the grasped diameter)."""
        self.set_finger_opening(width)

    # Position control (for simulated execution) ------------------------------------------

    def command_configuration(self, q: np.ndarray, forces: Sequence[float] | None = None,
                              position_gain: float | None = None) -> None:
        """Set position-control targets for the arm joints (takes effect on stepSimulation);
        ``position_gain``: PyBullet's position gain of every joint (``None``: its default)."""
        values = np.asarray(q, dtype=float)
        if values.shape != (self.dof,):
            raise ValueError(f"a Panda configuration has shape (7,), got {values.shape}")
        max_forces = list(forces) if forces is not None else [87.0] * 4 + [12.0] * 3
        pybullet.setJointMotorControlArray(
            self.body_id,
            PANDA_ARM_JOINTS,
            pybullet.POSITION_CONTROL,
            targetPositions=[float(v) for v in values],
            forces=max_forces,
            **({} if position_gain is None
               else {"positionGains": [float(position_gain)] * self.dof}),
            physicsClientId=self.client_id,
        )

    def command_gripper(self, width: float, force: float = 20.0) -> None:
        """Position-control the fingers towards an opening ``width`` (metres)."""
        per_finger = float(np.clip(width / 2.0, 0.0, PANDA_FINGER_TRAVEL))
        pybullet.setJointMotorControlArray(
            self.body_id,
            PANDA_FINGER_JOINTS,
            pybullet.POSITION_CONTROL,
            targetPositions=[per_finger, per_finger],
            forces=[force, force],
            physicsClientId=self.client_id,
        )
