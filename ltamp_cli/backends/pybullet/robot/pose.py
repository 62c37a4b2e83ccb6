"""Rigid transforms as (position, quaternion) pairs, pybullet's conventions.

Positions are metres, shape ``(3,)``; quaternions are ``(x, y, z, w)``, shape ``(4,)``.
Roll/pitch/yaw follow pybullet's ``getEulerFromQuaternion``: ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation


@dataclass(frozen=True)
class Pose:
    """Pose of a frame B in a frame A: ``p_A = R @ p_B + position``."""

    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    quaternion: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0]))

    def __post_init__(self) -> None:
        position = np.asarray(self.position, dtype=float).reshape(3)
        quaternion = np.asarray(self.quaternion, dtype=float).reshape(4)
        norm = float(np.linalg.norm(quaternion))
        if norm < 1e-9:
            raise ValueError("quaternion must be non-zero")
        object.__setattr__(self, "position", position)
        object.__setattr__(self, "quaternion", quaternion / norm)

    @classmethod
    def from_euler(
        cls, position: np.ndarray, roll: float = 0.0, pitch: float = 0.0, yaw: float = 0.0
    ) -> Pose:
        """Pose from a position and pybullet roll/pitch/yaw (radians)."""
        quaternion = Rotation.from_euler("xyz", [roll, pitch, yaw]).as_quat()
        return cls(np.asarray(position, dtype=float), quaternion)

    @classmethod
    def from_matrix(cls, matrix: np.ndarray) -> Pose:
        """Pose from a homogeneous 4×4 matrix."""
        array = np.asarray(matrix, dtype=float)
        return cls(array[:3, 3], Rotation.from_matrix(array[:3, :3]).as_quat())

    def rotation(self) -> np.ndarray:
        """Rotation matrix, shape ``(3, 3)``."""
        return Rotation.from_quat(self.quaternion).as_matrix()

    def matrix(self) -> np.ndarray:
        """Homogeneous matrix, shape ``(4, 4)``."""
        result = np.eye(4)
        result[:3, :3] = self.rotation()
        result[:3, 3] = self.position
        return result

    def __matmul__(self, other: Pose) -> Pose:
        """Composition: ``(A_T_B @ B_T_C) = A_T_C``."""
        rotation = Rotation.from_quat(self.quaternion)
        return Pose(
            self.position + rotation.apply(other.position),
            (rotation * Rotation.from_quat(other.quaternion)).as_quat(),
        )

    def inverse(self) -> Pose:
        inverse_rotation = Rotation.from_quat(self.quaternion).inv()
        return Pose(-inverse_rotation.apply(self.position), inverse_rotation.as_quat())

    def euler(self) -> np.ndarray:
        """``(roll, pitch, yaw)`` in radians, pybullet's convention."""
        return Rotation.from_quat(self.quaternion).as_euler("xyz")

    def as_tuples(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """``(position, quaternion)`` as plain tuples for pybullet calls."""
        return tuple(map(float, self.position)), tuple(map(float, self.quaternion))


def rotation_distance(a: Pose, b: Pose) -> float:
    """Angle (radians, in ``[0, π]``) of the rotation taking ``a``'s orientation to ``b``'s."""
    dot = abs(float(np.dot(a.quaternion, b.quaternion)))
    return 2.0 * float(np.arccos(min(1.0, dot)))


def interpolate_poses(a: Pose, b: Pose, fraction: float) -> Pose:
    """Linear position / spherical-linear orientation interpolation, ``fraction`` in [0, 1]."""
    qa = a.quaternion
    qb = b.quaternion
    dot = float(np.dot(qa, qb))
    if dot < 0.0:  # take the short way round
        qb = -qb
        dot = -dot
    if dot > 0.9995:
        quaternion = qa + fraction * (qb - qa)
    else:
        angle = np.arccos(dot)
        quaternion = (np.sin((1 - fraction) * angle) * qa + np.sin(fraction * angle) * qb) / np.sin(
            angle
        )
    return Pose(a.position + fraction * (b.position - a.position), quaternion)


def tilt_roll_pitch(pose: Pose) -> tuple[float, float]:
    """``(roll, pitch)`` of ``pose`` (pybullet convention); both are 0 for an upright frame.

    With ``R = Rz(yaw) Ry(pitch) Rx(roll)`` the frame's z axis has world-z component
    ``cos(roll) cos(pitch)``, so bounding |roll| and |pitch| bounds the tilt whatever the yaw.
    """
    roll, pitch, _ = pose.euler()
    return float(roll), float(pitch)
