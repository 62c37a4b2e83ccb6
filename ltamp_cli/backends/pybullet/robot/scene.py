"""Kitchen3D scenes: a table with one Panda, or two Pandas facing each other across it.

World frame: z up, floor at ``z = 0``, table centred on the origin with its top at
``TableSpec.height``. Arm 0 stands at ``-x`` facing ``+x``; arm 1 (two-arm scenes, the
paper's dual-arm problems) at ``+x`` facing ``-x``. Each arm's base sits on a pedestal at
table height, just off the table's edge.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet

from ltamp_cli.backends.pybullet.robot.arm import PandaArm
from ltamp_cli.backends.pybullet.robot.pose import Pose


@dataclass(frozen=True)
class TableSpec:
    """Table top size (metres): ``length`` along x, ``width`` along y; ``height`` of the top."""

    length: float = 0.9
    width: float = 0.9
    height: float = 0.7
    thickness: float = 0.04
    base_gap: float = 0.08
    """Horizontal distance from the table edge to each arm's base (metres)."""

    def __post_init__(self) -> None:
        if min(self.length, self.width, self.height, self.thickness) <= 0 or self.base_gap < 0:
            raise ValueError("table dimensions must be positive and base_gap >= 0")


@dataclass(frozen=True)
class KitchenScene:
    """Body ids of a built scene and its arms (all in ``client_id``)."""

    client_id: int
    table: TableSpec
    floor_id: int
    table_id: int
    pedestal_ids: tuple[int, ...]
    arms: tuple[PandaArm, ...]

    @property
    def table_centre(self) -> np.ndarray:
        """Centre of the table top surface, shape ``(3,)`` metres."""
        return np.array([0.0, 0.0, self.table.height])

    def static_bodies(self) -> tuple[int, ...]:
        return (self.floor_id, self.table_id, *self.pedestal_ids)

    def obstacles_for(self, arm_index: int, extra: Sequence[int] = ()) -> tuple[int, ...]:
        """Bodies arm ``arm_index`` must avoid: static scenery, the other arms, ``extra``."""
        others = tuple(arm.body_id for i, arm in enumerate(self.arms) if i != arm_index)
        return (*self.static_bodies(), *others, *(int(body) for body in extra))


def add_box(
    client_id: int,
    half_extents: Sequence[float],
    pose: Pose,
    *,
    mass: float = 0.0,
    rgba: Sequence[float] = (0.6, 0.6, 0.6, 1.0),
) -> int:
    """A box body (``mass`` 0: static) with collision and visual shapes; returns its id."""
    extents = [float(value) for value in half_extents]
    collision = pybullet.createCollisionShape(
        pybullet.GEOM_BOX, halfExtents=extents, physicsClientId=client_id
    )
    visual = pybullet.createVisualShape(
        pybullet.GEOM_BOX, halfExtents=extents, rgbaColor=list(rgba), physicsClientId=client_id
    )
    position, quaternion = pose.as_tuples()
    return pybullet.createMultiBody(
        baseMass=mass,
        baseCollisionShapeIndex=collision,
        baseVisualShapeIndex=visual,
        basePosition=position,
        baseOrientation=quaternion,
        physicsClientId=client_id,
    )


def add_cylinder(
    client_id: int,
    radius: float,
    height: float,
    pose: Pose,
    *,
    mass: float = 0.0,
    rgba: Sequence[float] = (0.8, 0.5, 0.3, 1.0),
) -> int:
    """A cylinder body centred at ``pose`` (axis along its z); returns its id."""
    collision = pybullet.createCollisionShape(
        pybullet.GEOM_CYLINDER, radius=radius, height=height, physicsClientId=client_id
    )
    visual = pybullet.createVisualShape(
        pybullet.GEOM_CYLINDER,
        radius=radius,
        length=height,
        rgbaColor=list(rgba),
        physicsClientId=client_id,
    )
    position, quaternion = pose.as_tuples()
    return pybullet.createMultiBody(
        baseMass=mass,
        baseCollisionShapeIndex=collision,
        baseVisualShapeIndex=visual,
        basePosition=position,
        baseOrientation=quaternion,
        physicsClientId=client_id,
    )


def build_kitchen_scene(
    client_id: int, n_arms: int = 1, table: TableSpec | None = None
) -> KitchenScene:
    """Add the floor, table, pedestals and ``n_arms`` (1 or 2) Pandas to ``client_id``."""
    if n_arms not in (1, 2):
        raise ValueError(f"n_arms must be 1 or 2, got {n_arms}")
    spec = table or TableSpec()
    floor_shape = pybullet.createCollisionShape(pybullet.GEOM_PLANE, physicsClientId=client_id)
    floor_id = pybullet.createMultiBody(
        baseMass=0.0, baseCollisionShapeIndex=floor_shape, physicsClientId=client_id
    )
    table_id = add_box(
        client_id,
        (spec.length / 2, spec.width / 2, spec.thickness / 2),
        Pose(np.array([0.0, 0.0, spec.height - spec.thickness / 2])),
        rgba=(0.75, 0.6, 0.45, 1.0),
    )
    pedestals = []
    arms = []
    base_x = spec.length / 2 + spec.base_gap
    for index in range(n_arms):
        side = -1.0 if index == 0 else 1.0
        yaw = 0.0 if index == 0 else np.pi
        pedestals.append(
            add_box(
                client_id,
                (0.1, 0.1, spec.height / 2),
                Pose(np.array([side * base_x, 0.0, spec.height / 2])),
                rgba=(0.3, 0.3, 0.3, 1.0),
            )
        )
        arms.append(
            PandaArm(client_id, Pose.from_euler([side * base_x, 0.0, spec.height], yaw=yaw))
        )
    return KitchenScene(client_id, spec, floor_id, table_id, tuple(pedestals), tuple(arms))
