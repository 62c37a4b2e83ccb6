"""PyBullet bodies built from the backend-independent kitchenware geometry.

Each convex piece of a :class:`~ltamp_cli.backends.kitchenware_geometry.KitchenwareGeometry`
becomes one ``GEOM_MESH`` collision shape made directly from its vertices (PyBullet takes
their convex hull); the pieces are the base and fixed-joint links of one multibody, so a
concave bowl collides exactly as the union of its convex parts. No files are written.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p

from ltamp_cli.backends.kitchenware_geometry import KitchenwareGeometry

IDENTITY_QUAT = (0.0, 0.0, 0.0, 1.0)


@dataclass(frozen=True)
class BodyMaterial:
    """Physical properties: ``mass`` in kg (0 = fixed in the world), friction, restitution,
    damping (1/s), and an RGBA display colour."""

    mass: float = 0.2
    lateral_friction: float = 0.5
    restitution: float = 0.1
    linear_damping: float = 0.04
    angular_damping: float = 0.04
    rgba: tuple[float, float, float, float] = (0.8, 0.8, 0.8, 1.0)


@dataclass(frozen=True)
class KitchenwareBody:
    """A created body: its PyBullet id, its client and the geometry it was made from.

    PyBullet reports and sets a base's pose at its centre of mass; ``com_offset`` (object
    frame, metres) converts so that :meth:`pose`/:meth:`set_pose` use the object frame.
    """

    body: int
    client: int
    geometry: KitchenwareGeometry
    com_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def links(self) -> tuple[int, ...]:
        """Link indices of all pieces (``-1`` is the base piece)."""
        return tuple(range(-1, len(self.geometry.pieces) - 1))

    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Position ``(3,)`` m and quaternion ``(4,)`` xyzw of the object frame."""
        position, orientation = p.getBasePositionAndOrientation(
            self.body, physicsClientId=self.client
        )
        rotation = _matrix(orientation)
        return np.asarray(position) - rotation @ np.asarray(self.com_offset), np.asarray(
            orientation
        )

    def set_pose(
        self,
        position: Sequence[float],
        orientation: Sequence[float] = IDENTITY_QUAT,
        linear_velocity: Sequence[float] = (0.0, 0.0, 0.0),
        angular_velocity: Sequence[float] = (0.0, 0.0, 0.0),
    ) -> None:
        """Place the object frame kinematically, with the velocity (of the object-frame
        origin, m/s, and angular, rad/s, world frame) that contacts should see."""
        lever = _matrix(orientation) @ np.asarray(self.com_offset)
        com = np.asarray(position, dtype=float) + lever
        com_velocity = np.asarray(linear_velocity, dtype=float) + np.cross(angular_velocity, lever)
        p.resetBasePositionAndOrientation(
            self.body, com.tolist(), list(orientation), physicsClientId=self.client
        )
        p.resetBaseVelocity(
            self.body, com_velocity.tolist(), list(angular_velocity), physicsClientId=self.client
        )


def create_kitchenware(
    client: int,
    geometry: KitchenwareGeometry,
    position: Sequence[float] = (0.0, 0.0, 0.0),
    orientation: Sequence[float] = IDENTITY_QUAT,
    material: BodyMaterial | None = None,
    visual: bool = True,
) -> KitchenwareBody:
    """Create ``geometry`` as one multibody in ``client``; mass is split by piece volume.

    With ``visual=True`` every piece also gets a triangle-mesh visual shape (for
    TinyRenderer images); it costs nothing in the physics step. Pieces of one body never
    collide with each other (PyBullet's default without self-collision flags).
    """
    material = material or BodyMaterial()
    volumes = geometry.piece_volumes()
    masses = material.mass * volumes / volumes.sum() if material.mass > 0 else 0.0 * volumes
    collision = [
        p.createCollisionShape(p.GEOM_MESH, vertices=piece.tolist(), physicsClientId=client)
        for piece in geometry.pieces
    ]
    if visual:
        visuals = []
        for hull in geometry.hulls():
            visuals.append(
                p.createVisualShape(
                    p.GEOM_MESH,
                    vertices=np.asarray(hull.vertices).tolist(),
                    indices=np.asarray(hull.faces).reshape(-1).tolist(),
                    rgbaColor=list(material.rgba),
                    physicsClientId=client,
                )
            )
    else:
        visuals = [-1] * len(collision)
    n = len(collision) - 1
    zero = [0.0, 0.0, 0.0]
    # Inertial frames at each piece's own centroid keep the fixed-link dynamics well posed.
    centroids = [np.asarray(piece).mean(axis=0).tolist() for piece in geometry.pieces]
    com_offset = tuple(centroids[0]) if material.mass > 0 else (0.0, 0.0, 0.0)
    body = p.createMultiBody(
        baseMass=float(masses[0]),
        baseCollisionShapeIndex=collision[0],
        baseVisualShapeIndex=visuals[0],
        # createMultiBody takes the link frame; get/resetBasePosition use the centre of mass.
        basePosition=list(position),
        baseOrientation=list(orientation),
        baseInertialFramePosition=list(com_offset),
        linkMasses=[float(m) for m in masses[1:]],
        linkCollisionShapeIndices=collision[1:],
        linkVisualShapeIndices=visuals[1:],
        linkPositions=[zero] * n,
        linkOrientations=[list(IDENTITY_QUAT)] * n,
        linkInertialFramePositions=centroids[1:] if material.mass > 0 else [zero] * n,
        linkInertialFrameOrientations=[list(IDENTITY_QUAT)] * n,
        linkParentIndices=[0] * n,
        linkJointTypes=[p.JOINT_FIXED] * n,
        linkJointAxis=[[0.0, 0.0, 1.0]] * n,
        physicsClientId=client,
    )
    if body < 0:
        raise RuntimeError(f"PyBullet could not create the {geometry.kind}")
    for link in range(-1, n):
        p.changeDynamics(
            body,
            link,
            lateralFriction=material.lateral_friction,
            restitution=material.restitution,
            linearDamping=material.linear_damping,
            angularDamping=material.angular_damping,
            physicsClientId=client,
        )
    return KitchenwareBody(body, client, geometry, com_offset)  # type: ignore[arg-type]


def _matrix(quaternion: Sequence[float]) -> np.ndarray:
    return np.asarray(p.getMatrixFromQuaternion(list(quaternion)), dtype=float).reshape(3, 3)


def world_to_object(
    points: np.ndarray, position: np.ndarray, orientation: np.ndarray
) -> np.ndarray:
    """Express world points ``(n, 3)`` in the frame at ``position`` ``(3,)`` with quaternion
    ``orientation`` ``(4,)`` (xyzw)."""
    rotation = _matrix(orientation)
    return (np.asarray(points, dtype=float).reshape(-1, 3) - np.asarray(position)) @ rotation
