"""Procedural kitchenware as backend-independent convex pieces (numpy + trimesh).

Every object is described in its own *object frame*, in metres:

* vessels (bowls, cups, the spoon head) have the centre of the bottom of their base at the
  origin and open towards ``+z``;
* each object is a tuple of convex pieces, each an ``(k, 3)`` array of vertices whose convex
  hull is the piece. A physics backend turns every piece into one convex collision shape
  (PyBullet: ``GEOM_MESH`` from vertices; SAPIEN: a convex mesh), so a concave bowl is an
  exact union of convex parts rather than an approximate decomposition.

Vessels are *revolved profiles*: a straight outer wall from ``(base_radius, 0)`` to
``(top_radius, height)`` in the ``(r, z)`` half plane, a wall ``thickness`` thick measured
horizontally inward, and a flat base disc ``thickness`` thick. The wall is split into
``segments`` angular sectors, each one convex 8-vertex piece.

The module also holds the cheap geometric tests the skills use before simulating (is a set
of points inside a vessel's material, inflated by a margin?) and containment regions used to
count particles.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np
import trimesh

DEFAULT_THICKNESS_M = 0.004
DEFAULT_SEGMENTS = 16


@dataclass(frozen=True)
class VesselDims:
    """Measured-style dimensions of a cylindrically symmetric bowl or cup (metres).

    ``base_diameter`` and ``top_diameter`` are *outer* diameters at the bottom and at the
    rim, ``height`` the outer height, ``thickness`` the wall and base thickness.
    """

    base_diameter: float
    top_diameter: float
    height: float
    thickness: float = DEFAULT_THICKNESS_M

    def __post_init__(self) -> None:
        for name in ("base_diameter", "top_diameter", "height", "thickness"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive finite length, got {value!r}")
        if 2.0 * self.thickness >= min(self.base_diameter, self.top_diameter) / 2.0:
            raise ValueError("thickness must be less than a quarter of the smaller diameter")
        if self.thickness >= self.height / 2.0:
            raise ValueError("thickness must be less than half the height")

    @property
    def base_radius(self) -> float:
        return self.base_diameter / 2.0

    @property
    def top_radius(self) -> float:
        return self.top_diameter / 2.0

    @property
    def max_radius(self) -> float:
        return max(self.base_radius, self.top_radius)

    def outer_radius_at(self, z: np.ndarray | float) -> np.ndarray:
        """Outer wall radius at height ``z`` (linear between base and rim), same shape."""
        fraction = np.clip(np.asarray(z, dtype=float) / self.height, 0.0, 1.0)
        return self.base_radius + fraction * (self.top_radius - self.base_radius)

    def cavity_volume(self) -> float:
        """Volume of the open interior above the base, in m^3 (a frustum)."""
        r0 = self.outer_radius_at(self.thickness) - self.thickness
        r1 = self.top_radius - self.thickness
        depth = self.height - self.thickness
        return float(math.pi * depth / 3.0 * (r0 * r0 + r0 * r1 + r1 * r1))

    def scaled(self, diameter_scale: float, height_scale: float) -> VesselDims:
        """The same shape scaled independently in diameter and height (thickness kept)."""
        return VesselDims(
            self.base_diameter * diameter_scale,
            self.top_diameter * diameter_scale,
            self.height * height_scale,
            self.thickness,
        )


@dataclass(frozen=True)
class ContainmentPrism:
    """An axis-aligned box in an object's frame; a particle inside it counts as contained.

    ``low``/``high`` have shape ``(3,)``, metres in the object frame.
    """

    low: tuple[float, float, float]
    high: tuple[float, float, float]

    def contains(self, points_object: np.ndarray) -> np.ndarray:
        """Bool mask ``(n,)`` for points ``(n, 3)`` expressed in the object frame."""
        points = np.asarray(points_object, dtype=float).reshape(-1, 3)
        return np.all((points >= np.asarray(self.low)) & (points <= np.asarray(self.high)), axis=1)


@dataclass(frozen=True, eq=False)
class KitchenwareGeometry:
    """One object's convex pieces (each ``(k, 3)`` vertices, object frame, metres).

    ``cavity`` is the containment prism for vessels (``None`` for solid objects);
    ``kind`` is a short label such as ``"bowl"``; ``vessel`` keeps the revolved dimensions of
    vessels (bowls, cups) for analytic tests.
    """

    kind: str
    pieces: tuple[np.ndarray, ...]
    cavity: ContainmentPrism | None = None
    vessel: VesselDims | None = None
    extra: dict[str, float] = field(default_factory=dict)
    #: Index of the first piece that is not part of the revolved vessel (0: none).
    extra_pieces_start: int = 0

    def hulls(self) -> list[trimesh.Trimesh]:
        """The pieces as trimesh convex hulls (for mass properties, rendering, export)."""
        return [trimesh.convex.convex_hull(piece) for piece in self.pieces]

    def mesh(self) -> trimesh.Trimesh:
        """All pieces concatenated into one (non-manifold) triangle mesh for display."""
        return trimesh.util.concatenate(self.hulls())

    def piece_volumes(self) -> np.ndarray:
        """Volume of every piece in m^3, shape ``(n_pieces,)``."""
        return np.array([hull.volume for hull in self.hulls()], dtype=float)

    def volume(self) -> float:
        return float(self.piece_volumes().sum())

    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds ``(2, 3)``: row 0 minimum, row 1 maximum (object frame)."""
        stacked = np.concatenate(self.pieces, axis=0)
        return np.stack([stacked.min(axis=0), stacked.max(axis=0)])

    def surface_points(self, spacing: float) -> np.ndarray:
        """Deterministic points on the surface of every piece, about ``spacing`` apart.

        Shape ``(n, 3)``. Used by collision pre-checks: any surface crossing another
        object's material passes within ``spacing`` of one of these points.
        """
        if spacing <= 0:
            raise ValueError("spacing must be positive")
        chunks = []
        for index, hull in enumerate(self.hulls()):
            count = max(8, math.ceil(hull.area / (spacing * spacing)))
            points, _ = trimesh.sample.sample_surface(hull, count, seed=index)
            chunks.append(np.asarray(points, dtype=float))
            chunks.append(np.asarray(hull.vertices, dtype=float))
        return np.concatenate(chunks, axis=0)


def vessel_mid_surface_points(dims: VesselDims, spacing: float) -> np.ndarray:
    """Points ``(n, 3)`` about ``spacing`` apart on the mid-surface of a vessel's base and
    wall (half a thickness inside the material). Far fewer than surface samples of the
    pieces, for the same collision pre-check once ``thickness / 2`` is added to the margin.
    """
    half = dims.thickness / 2.0
    rz = [(0.0, half)]
    n_base = max(1, math.ceil((dims.base_radius - half) / spacing))
    rz += [(r, half) for r in np.linspace(0.0, dims.base_radius - half, n_base + 1)[1:]]
    wall_length = math.hypot(dims.top_radius - dims.base_radius, dims.height)
    n_wall = max(1, math.ceil(wall_length / spacing))
    for t in np.linspace(0.0, 1.0, n_wall + 1):
        r = dims.base_radius - half + t * (dims.top_radius - dims.base_radius)
        rz.append((r, t * dims.height))
    rings = []
    for r, z in rz:
        count = max(1, math.ceil(2.0 * math.pi * r / spacing))
        angles = np.linspace(0.0, 2.0 * math.pi, count, endpoint=False)
        rings.append(_ring(r, z, angles))
    return np.concatenate(rings)


def check_points(geometry: KitchenwareGeometry, spacing: float) -> tuple[np.ndarray, float]:
    """Points ``(n, 3)`` representing ``geometry`` for collision pre-checks and the extra
    margin (metres) they need: mid-surface rings for the revolved part, surface samples
    (margin 0) for the other pieces. Pieces are ordered base, wall sectors, then extras.
    """
    if geometry.vessel is None:
        return geometry.surface_points(spacing), 0.0
    dims = geometry.vessel
    points = [vessel_mid_surface_points(dims, spacing)]
    extras = geometry.pieces[geometry.extra_pieces_start :] if geometry.extra_pieces_start else ()
    for index, piece in enumerate(extras):
        hull = trimesh.convex.convex_hull(piece)
        count = max(8, math.ceil(hull.area / (spacing * spacing)))
        sampled, _ = trimesh.sample.sample_surface(hull, count, seed=index)
        points.append(np.asarray(sampled, dtype=float))
    return np.concatenate(points), dims.thickness / 2.0


def _ring(radius: float, z: float, angles: np.ndarray) -> np.ndarray:
    return np.stack([radius * np.cos(angles), radius * np.sin(angles), np.full_like(angles, z)], 1)


def revolved_shell_pieces(
    dims: VesselDims, segments: int = DEFAULT_SEGMENTS
) -> tuple[np.ndarray, ...]:
    """Convex pieces of an open vessel: one base disc then ``segments`` wall sectors.

    The base disc is a ``segments``-gon prism of the outer base radius; each wall sector
    spans ``2π/segments`` with 8 vertices (outer/inner × bottom/top × two angles).
    """
    if segments < 6:
        raise ValueError("segments must be at least 6")
    t = dims.thickness
    angles = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    base = np.concatenate(
        [_ring(dims.base_radius, 0.0, angles), _ring(dims.base_radius, t, angles)]
    )
    pieces = [base]
    edges = np.linspace(0.0, 2.0 * math.pi, segments + 1)
    for a0, a1 in itertools.pairwise(edges):
        pair = np.array([a0, a1])
        corners = []
        for radius, z in (
            (dims.base_radius, 0.0),
            (dims.top_radius, dims.height),
        ):
            corners.append(_ring(radius, z, pair))
            corners.append(_ring(radius - t, z, pair))
        pieces.append(np.concatenate(corners))
    return tuple(pieces)


def vessel_geometry(
    dims: VesselDims, kind: str = "bowl", segments: int = DEFAULT_SEGMENTS
) -> KitchenwareGeometry:
    """A bowl or cup: revolved convex pieces plus its containment prism.

    The prism is the vessel's bounding box above the base: ``|x|, |y| ≤ max radius``,
    ``thickness ≤ z ≤ height``.
    """
    r = dims.max_radius
    cavity = ContainmentPrism((-r, -r, dims.thickness), (r, r, dims.height))
    return KitchenwareGeometry(kind, revolved_shell_pieces(dims, segments), cavity, dims)


def box_piece(center: np.ndarray, half_extents: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """8 vertices ``(8, 3)`` of a box with ``rotation`` ``(3, 3)`` about ``center`` ``(3,)``."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
    return np.asarray(center) + (signs * np.asarray(half_extents)) @ np.asarray(rotation).T


def _rotation_x(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


@dataclass(frozen=True)
class SpoonDims:
    """A spoon: a small revolved head (a shallow cup) and a straight flat handle.

    ``length`` is the total length in metres; the head scales with it. The handle leaves
    the head's rim on the ``+y`` side, tilted up by ``handle_angle`` radians.
    """

    length: float
    handle_angle: float = math.radians(30.0)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.length) and 0.05 <= self.length <= 1.0):
            raise ValueError(f"spoon length must be within [0.05, 1.0] m, got {self.length!r}")

    def head(self) -> VesselDims:
        top = 0.3 * self.length
        return VesselDims(0.6 * top, top, 0.35 * top, thickness=0.002)


def spoon_geometry(dims: SpoonDims, segments: int = 12) -> KitchenwareGeometry:
    """Spoon pieces (head sectors, head base, handle box) and the head's containment prism."""
    head = dims.head()
    pieces = list(revolved_shell_pieces(head, segments))
    handle_length = max(dims.length - head.top_diameter, 0.02)
    direction = np.array([0.0, math.cos(dims.handle_angle), math.sin(dims.handle_angle)])
    start = np.array([0.0, head.top_radius - head.thickness, head.height])
    center = start + direction * handle_length / 2.0
    rotation = _rotation_x(dims.handle_angle)
    pieces.append(box_piece(center, np.array([0.006, handle_length / 2.0, 0.002]), rotation))
    r = head.top_radius
    cavity = ContainmentPrism((-r, -r, head.thickness), (r, r, head.height))
    return KitchenwareGeometry(
        "spoon", tuple(pieces), cavity, head, {"length": dims.length}, len(pieces) - 1
    )


def stirrer_geometry(length: float = 0.2, radius: float = 0.004) -> KitchenwareGeometry:
    """A stirrer: one octagonal rod along ``+z`` from the origin."""
    angles = np.linspace(0.0, 2.0 * math.pi, 8, endpoint=False)
    rod = np.concatenate([_ring(radius, 0.0, angles), _ring(radius, length, angles)])
    return KitchenwareGeometry("stirrer", (rod,), extra={"length": length})


def block_geometry(size: tuple[float, float, float] = (0.05, 0.05, 0.05)) -> KitchenwareGeometry:
    """A block resting on ``z = 0`` centred on the z axis, ``size`` full extents in metres."""
    half = np.asarray(size, dtype=float) / 2.0
    piece = box_piece(np.array([0.0, 0.0, half[2]]), half, np.eye(3))
    return KitchenwareGeometry("block", (piece,))


def faucet_geometry(
    height: float = 0.35, reach: float = 0.2, width: float = 0.03
) -> KitchenwareGeometry:
    """A faucet: a vertical column at the origin and a horizontal spout towards ``+x``.

    The spout outlet (where particles would be emitted) is at ``extra['outlet_x'/'outlet_z']``.
    """
    half = width / 2.0
    column = box_piece(
        np.array([0.0, 0.0, height / 2.0]), np.array([half, half, height / 2]), np.eye(3)
    )
    spout = box_piece(
        np.array([reach / 2.0, 0.0, height - half]), np.array([reach / 2.0, half, half]), np.eye(3)
    )
    return KitchenwareGeometry(
        "faucet", (column, spout), extra={"outlet_x": reach - half, "outlet_z": height - width}
    )


def points_in_vessel_wall(
    points_vessel: np.ndarray, dims: VesselDims, margin: float = 0.0
) -> np.ndarray:
    """Which points ``(n, 3)`` (vessel frame) lie within the vessel's material inflated by
    ``margin`` metres. Returns a bool mask ``(n,)``.

    Works in the ``(r, z)`` half plane: the material is the base slab and the slanted wall,
    each a segment of the mid-surface widened by ``thickness / 2 + margin``.
    """
    points = np.asarray(points_vessel, dtype=float).reshape(-1, 3)
    rz = np.stack([np.hypot(points[:, 0], points[:, 1]), points[:, 2]], axis=1)
    half = dims.thickness / 2.0
    base_segment = (np.array([0.0, half]), np.array([dims.base_radius - half, half]))
    wall_segment = (
        np.array([dims.base_radius - half, 0.0]),
        np.array([dims.top_radius - half, dims.height]),
    )
    reach = half + margin
    hit = np.zeros(len(rz), dtype=bool)
    for a, b in (base_segment, wall_segment):
        hit |= _distance_to_segment(rz, a, b) <= reach
    return hit


def _distance_to_segment(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip(((points - a) @ ab) / float(ab @ ab), 0.0, 1.0)
    closest = a + t[:, None] * ab
    return np.linalg.norm(points - closest, axis=1)


__all__ = [
    "ContainmentPrism",
    "KitchenwareGeometry",
    "SpoonDims",
    "VesselDims",
    "block_geometry",
    "box_piece",
    "check_points",
    "faucet_geometry",
    "points_in_vessel_wall",
    "revolved_shell_pieces",
    "spoon_geometry",
    "stirrer_geometry",
    "vessel_geometry",
    "vessel_mid_surface_points",
]
