"""Particles ("beads"): small spheres standing in for liquid or granular contents.

Beads are spawned on a jittered grid inside a vessel's cavity and counted as *contained*
when their centre lies inside the container's bounding prism, expressed in the container's
own frame (so a tilted cup is counted correctly).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p

from ltamp_cli.backends.kitchenware_geometry import ContainmentPrism, VesselDims
from ltamp_cli.backends.pybullet.kitchenware import KitchenwareBody, world_to_object


@dataclass(frozen=True)
class BeadSpec:
    """Up to ``count`` spheres of ``radius`` m and ``mass`` kg each, with contact properties.

    ``rolling_friction`` and ``spinning_friction`` are Bullet's coefficients (m); ``damping``
    is the linear and angular velocity damping (1/s). ``fill_height`` (m above the vessel's
    frame origin, its outer base) caps the bead *tops* when filling a vessel: only the beads
    that fit below it are created. ``None``: a column up to 4 × the vessel's height, so an
    overfull vessel spills while settling.
    """

    count: int
    radius: float = 0.006
    mass: float = 0.002
    lateral_friction: float = 0.5
    restitution: float = 0.7
    rgba: tuple[float, float, float, float] = (0.2, 0.4, 0.9, 1.0)
    rolling_friction: float = 1e-5
    spinning_friction: float = 0.0
    damping: float = 0.04
    fill_height: float | None = None

    def __post_init__(self) -> None:
        if self.count < 0:
            raise ValueError("count must be non-negative")
        if not (self.radius > 0 and self.mass > 0):
            raise ValueError("radius and mass must be positive")
        if self.fill_height is not None and not self.fill_height > 0:
            raise ValueError("fill_height must be positive")

    @property
    def volume(self) -> float:
        return 4.0 / 3.0 * math.pi * self.radius**3


def grid_in_vessel(
    dims: VesselDims, spec: BeadSpec, rng: np.random.Generator, max_height: float | None = None
) -> np.ndarray:
    """Up to ``spec.count`` bead centres ``(n, 3)`` (vessel frame) on a jittered grid that
    fills the cavity from the floor up; above the rim the column keeps the rim's radius up
    to ``max_height`` (default 2 × height), so overfull vessels spill when settling.
    """
    spacing = 2.0 * spec.radius * 1.08
    floor = dims.thickness + spec.radius * 1.05
    top = max_height if max_height is not None else 2.0 * dims.height
    centres: list[np.ndarray] = []
    z = floor
    while z <= top and len(centres) < spec.count:
        inner = float(dims.outer_radius_at(min(z, dims.height))) - dims.thickness
        usable = inner - spec.radius * 1.1
        if usable > 0:
            n_side = math.floor(usable / spacing)
            ticks = np.arange(-n_side, n_side + 1) * spacing
            xs, ys = np.meshgrid(ticks, ticks, indexing="ij")
            layer = np.stack([xs.ravel(), ys.ravel()], axis=1)
            layer = layer[np.hypot(layer[:, 0], layer[:, 1]) <= usable]
            for xy in layer[rng.permutation(len(layer))]:
                centres.append(np.array([xy[0], xy[1], z]))
                if len(centres) == spec.count:
                    break
        z += spacing
    if not centres:
        return np.zeros((0, 3))
    points = np.stack(centres)
    jitter = rng.uniform(-0.02, 0.02, size=points.shape) * spec.radius
    return points + jitter


def bead_layout(dims: VesselDims, spec: BeadSpec, rng: np.random.Generator) -> np.ndarray:
    """Bead centres ``(n, 3)`` in a vessel's frame for ``spec`` (shared by every engine, so
    the same draws from ``rng`` give the same beads): up to ``spec.fill_height`` when it is
    set, else a column up to 4 × the vessel's height."""
    if spec.fill_height is None:
        return grid_in_vessel(dims, spec, rng, max_height=4.0 * dims.height)
    return grid_in_vessel(dims, spec, rng, max_height=spec.fill_height - spec.radius)


def spawn_beads(client: int, spec: BeadSpec, positions_world: np.ndarray) -> np.ndarray:
    """Create one sphere per row of ``positions_world`` ``(n, 3)``; returns body ids ``(n,)``."""
    shape = p.createCollisionShape(p.GEOM_SPHERE, radius=spec.radius, physicsClientId=client)
    visual = p.createVisualShape(
        p.GEOM_SPHERE, radius=spec.radius, rgbaColor=list(spec.rgba), physicsClientId=client
    )
    ids = []
    for position in np.asarray(positions_world, dtype=float).reshape(-1, 3):
        body = p.createMultiBody(
            spec.mass, shape, visual, position.tolist(), physicsClientId=client
        )
        p.changeDynamics(
            body,
            -1,
            lateralFriction=spec.lateral_friction,
            restitution=spec.restitution,
            rollingFriction=spec.rolling_friction,
            spinningFriction=spec.spinning_friction,
            linearDamping=spec.damping,
            angularDamping=spec.damping,
            physicsClientId=client,
        )
        ids.append(body)
    return np.asarray(ids, dtype=int)


def spawn_beads_in(
    container: KitchenwareBody, spec: BeadSpec, rng: np.random.Generator
) -> np.ndarray:
    """Spawn up to ``spec.count`` beads inside ``container`` (a vessel) at its current pose
    (:func:`bead_layout`)."""
    dims = container.geometry.vessel
    if dims is None:
        raise ValueError(f"a {container.geometry.kind} is not a vessel: cannot hold beads")
    local = bead_layout(dims, spec, rng)
    position, orientation = container.pose()
    rotation = np.asarray(p.getMatrixFromQuaternion(list(orientation))).reshape(3, 3)
    return spawn_beads(container.client, spec, local @ rotation.T + position)


def bead_positions(client: int, beads: Sequence[int] | np.ndarray) -> np.ndarray:
    """World positions ``(n, 3)`` of the beads, metres."""
    if len(beads) == 0:
        return np.zeros((0, 3))
    return np.array(
        [p.getBasePositionAndOrientation(int(b), physicsClientId=client)[0] for b in beads]
    )


def contained_mask(container: KitchenwareBody, positions_world: np.ndarray) -> np.ndarray:
    """Bool mask ``(n,)``: which bead centres lie in ``container``'s containment prism."""
    prism: ContainmentPrism | None = container.geometry.cavity
    if prism is None:
        raise ValueError(f"a {container.geometry.kind} has no cavity to contain beads")
    position, orientation = container.pose()
    return prism.contains(world_to_object(positions_world, position, orientation))


def count_lost(positions_world: np.ndarray, floor_z: float = -0.01) -> int:
    """Beads that went below the table (tunnelled through it): should always be 0."""
    return int((np.asarray(positions_world).reshape(-1, 3)[:, 2] < floor_z).sum())


def count_contained(
    containers: dict[str, KitchenwareBody], positions_world: np.ndarray
) -> dict[str, int]:
    """Number of beads contained in each named container."""
    return {
        name: int(contained_mask(body, positions_world).sum()) for name, body in containers.items()
    }
