"""Rigid tool paths: waypoint poses, resampling by distance, and moving point clouds.

A pose is a position ``(3,)`` in metres and a quaternion ``(4,)`` (x, y, z, w). Paths are
arrays ``positions (k, 3)`` and ``quaternions (k, 4)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation, Slerp


@dataclass(frozen=True, eq=False)
class PosePath:
    """Waypoint poses of a rigid object: ``positions (k, 3)`` m, ``quaternions (k, 4)`` xyzw."""

    positions: np.ndarray
    quaternions: np.ndarray

    def __len__(self) -> int:
        return len(self.positions)

    def rotations(self) -> Rotation:
        return Rotation.from_quat(self.quaternions)

    def transform(self, points_object: np.ndarray) -> np.ndarray:
        """Object-frame points ``(m, 3)`` placed at every pose: ``(k, m, 3)`` world points."""
        matrices = self.rotations().as_matrix()  # (k, 3, 3)
        return np.einsum("kij,mj->kmi", matrices, points_object) + self.positions[:, None, :]

    def densify(self, points_object: np.ndarray, max_move: float) -> PosePath:
        """Resample so no point of ``points_object`` ``(m, 3)`` moves more than ``max_move``
        metres between consecutive poses (interpolating linearly and by slerp)."""
        if len(self) < 2:
            return self
        # |T1 p - T0 p| is convex in p, so its maximum over the points is attained at a
        # corner of their bounding box.
        low, high = points_object.min(axis=0), points_object.max(axis=0)
        corners = np.array(
            [
                [x, y, z]
                for x in (low[0], high[0])
                for y in (low[1], high[1])
                for z in (low[2], high[2])
            ]
        )
        placed = self.transform(corners)  # (k, 8, 3)
        positions, quaternions = [self.positions[:1]], [self.quaternions[:1]]
        for i in range(len(self) - 1):
            move = float(np.linalg.norm(placed[i + 1] - placed[i], axis=1).max())
            n = max(1, math.ceil(move / max_move))
            t = np.linspace(0.0, 1.0, n + 1)[1:]
            segment = interpolate(self, i, t)
            positions.append(segment.positions)
            quaternions.append(segment.quaternions)
        return PosePath(np.concatenate(positions), np.concatenate(quaternions))


def interpolate(path: PosePath, index: int, t: np.ndarray) -> PosePath:
    """Poses between waypoint ``index`` and ``index + 1`` at fractions ``t`` ``(n,)``."""
    p0, p1 = path.positions[index], path.positions[index + 1]
    positions = p0 + np.asarray(t)[:, None] * (p1 - p0)
    slerp = Slerp([0.0, 1.0], Rotation.from_quat(path.quaternions[index : index + 2]))
    return PosePath(positions, slerp(np.asarray(t)).as_quat())


def segment_steps(shift: float, turn: float, speed: float, angular_speed: float,
                  dt: float) -> int:
    """Simulation steps of ``dt`` s for a segment that moves ``shift`` m and turns ``turn``
    rad: the longer of ``shift / speed`` and ``turn / angular_speed``, at least one step."""
    return max(1, round(max(shift / speed, turn / angular_speed, dt) / dt))


def timed_poses(path: PosePath, speed: float, angular_speed: float, dt: float) -> PosePath:
    """Resample ``path`` at simulation steps of ``dt`` s: each segment takes the longer of
    ``distance / speed`` and ``angle / angular_speed`` seconds. Shape ``(n_steps + 1, ·)``."""
    positions, quaternions = [path.positions[:1]], [path.quaternions[:1]]
    rotations = path.rotations()
    for i in range(len(path) - 1):
        shift = float(np.linalg.norm(path.positions[i + 1] - path.positions[i]))
        turn = float((rotations[i].inv() * rotations[i + 1]).magnitude())
        n = segment_steps(shift, turn, speed, angular_speed, dt)
        segment = interpolate(path, i, np.linspace(0.0, 1.0, n + 1)[1:])
        positions.append(segment.positions)
        quaternions.append(segment.quaternions)
    return PosePath(np.concatenate(positions), np.concatenate(quaternions))


def velocities(path: PosePath, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Finite-difference linear ``(k, 3)`` m/s and angular ``(k, 3)`` rad/s (world frame)
    velocities that carry each pose to the next in ``dt``; the last is zero."""
    linear = np.zeros_like(path.positions)
    angular = np.zeros_like(path.positions)
    if len(path) > 1:
        linear[:-1] = np.diff(path.positions, axis=0) / dt
        rotations = path.rotations()
        delta = rotations[1:] * rotations[:-1].inv()
        angular[:-1] = delta.as_rotvec() / dt
    return linear, angular


def rotation_about_axis(axis: str, angle: float) -> np.ndarray:
    """Quaternion ``(4,)`` xyzw of a rotation by ``angle`` rad about ``'x'``/``'y'``/``'z'``."""
    return Rotation.from_euler(axis, angle).as_quat()
