"""Kitchen3D planning scenes: which kitchenware stands where, read from a problem's ``world``.

A problem's ``world`` mapping (YAML) describes the objects' shapes; *movable* objects get
their poses from the problem's ``objects``/``init`` (``AtPose``), *fixed* ones (bowls bolted
to the table, the faucet) from ``at``::

    world:
      arms: 1                      # 1: one Panda at -x; 2: a second one at +x
      table: {length: 0.9, width: 0.9}   # optional: the table top (m), x and y extents
      objects:
        cup:    {kind: cup, top_diameter: 0.07, base_diameter: 0.06, height: 0.09,
                 contents: {material: water, beads: 60}}
        bowl:   {kind: bowl, top_diameter: 0.2, base_diameter: 0.12, height: 0.07,
                 fixed: true, at: [0.05, -0.12]}
        block:  {kind: block, size: [0.04, 0.2, 0.14]}
        spoon:  {kind: spoon, length: 0.2}
        stirrer: {kind: stirrer, length: 0.2}
        faucet: {kind: faucet, fixed: true, at: [0.2, 0.0], height: 0.35, reach: 0.2}
      regions:                     # axis-aligned rectangles on the table: [[x0, x1], [y0, y1]]
        table: [[-0.25, 0.3], [-0.35, 0.35]]

Frames: the world frame of :mod:`ltamp_cli.backends.pybullet.robot.scene` (table top at
``TableSpec.height``). A *pose value* is ``(x, y)`` in metres: the object's base centre on
the table top, upright, unrotated.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ltamp_cli.backends.kitchenware_geometry import (
    KitchenwareGeometry,
    SpoonDims,
    VesselDims,
    block_geometry,
    faucet_geometry,
    spoon_geometry,
    stirrer_geometry,
    vessel_geometry,
)
from ltamp_cli.backends.pybullet.robot.scene import TableSpec
from ltamp_cli.errors import InputError

KINDS = ("cup", "bowl", "block", "spoon", "stirrer", "faucet")
XY = tuple[float, float]


@dataclass(frozen=True)
class Contents:
    """``beads`` particles of ``material`` (a PDDL object name such as ``water``)."""

    material: str
    beads: int


@dataclass(frozen=True)
class ObjectSpec:
    """One object: ``kind`` (see :data:`KINDS`), its dimensions (metres), whether it is
    ``fixed`` (then ``at`` is its pose value) and what it initially ``contents``."""

    name: str
    kind: str
    dims: Mapping[str, Any] = field(default_factory=dict)
    fixed: bool = False
    at: XY | None = None
    contents: Contents | None = None

    def vessel(self) -> VesselDims:
        """Cup or bowl dimensions."""
        d = self.dims
        return VesselDims(float(d["base_diameter"]), float(d["top_diameter"]), float(d["height"]))

    def geometry(self) -> KitchenwareGeometry:
        """The procedural geometry in the object frame (base centre at the origin)."""
        if self.kind in ("cup", "bowl"):
            return vessel_geometry(self.vessel(), self.kind)
        if self.kind == "block":
            return block_geometry(tuple(float(v) for v in self.dims["size"]))  # type: ignore[arg-type]
        if self.kind == "spoon":
            return spoon_geometry(SpoonDims(float(self.dims["length"])))
        if self.kind == "stirrer":
            return stirrer_geometry(float(self.dims.get("length", 0.2)))
        return faucet_geometry(float(self.dims.get("height", 0.35)),
                               float(self.dims.get("reach", 0.2)))

    def footprint(self) -> tuple[float, float]:
        """Half extents ``(hx, hy)`` of the object's footprint on the table, metres."""
        if self.kind in ("cup", "bowl"):
            r = self.vessel().max_radius
            return r, r
        if self.kind == "block":
            size = self.dims["size"]
            return float(size[0]) / 2.0, float(size[1]) / 2.0
        bounds = self.geometry().bounds()
        return float(max(-bounds[0][0], bounds[1][0])), float(max(-bounds[0][1], bounds[1][1]))

    @property
    def height(self) -> float:
        return float(self.geometry().bounds()[1][2])


@dataclass(frozen=True)
class Region:
    """An axis-aligned rectangle of the table top: ``x`` and ``y`` ranges in metres."""

    name: str
    x: tuple[float, float]
    y: tuple[float, float]

    def contains(self, xy: XY, half: tuple[float, float] = (0.0, 0.0)) -> bool:
        """The footprint of half extents ``half`` centred at ``xy`` lies inside."""
        return (self.x[0] + half[0] - 1e-9 <= xy[0] <= self.x[1] - half[0] + 1e-9
                and self.y[0] + half[1] - 1e-9 <= xy[1] <= self.y[1] - half[1] + 1e-9)


@dataclass(frozen=True)
class SceneSpec:
    """Objects and regions of one Kitchen3D planning problem, the number of arms and the
    table (the arms stand just off its ``±x`` edges)."""

    objects: Mapping[str, ObjectSpec]
    regions: Mapping[str, Region]
    n_arms: int = 1
    table: TableSpec = field(default_factory=TableSpec)

    def object(self, name: str) -> ObjectSpec:
        try:
            return self.objects[name]
        except KeyError:
            raise InputError(f"world.objects: no object named {name!r}") from None

    def movable(self) -> tuple[str, ...]:
        return tuple(name for name, spec in self.objects.items() if not spec.fixed)


_DIMENSIONS = {
    "cup": ("top_diameter", "base_diameter", "height"),
    "bowl": ("top_diameter", "base_diameter", "height"),
    "block": ("size",),
    "spoon": ("length",),
    "stirrer": (),
    "faucet": (),
}
_OPTIONAL = {"stirrer": ("length",), "faucet": ("height", "reach")}


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(f"{where}: expected a number (metres), got {value!r}")
    return float(value)


def _pair(value: Any, where: str) -> tuple[float, float]:
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise InputError(f"{where}: expected two numbers [x, y] or [low, high], got {value!r}")
    return _number(value[0], where), _number(value[1], where)


def _object(name: str, raw: Any) -> ObjectSpec:
    where = f"world.objects.{name}"
    if not isinstance(raw, Mapping):
        raise InputError(f"{where}: expected a mapping with 'kind' and dimensions")
    kind = raw.get("kind")
    if kind not in KINDS:
        raise InputError(f"{where}.kind: expected one of {', '.join(KINDS)}, got {kind!r}")
    allowed = {"kind", "fixed", "at", "contents", *_DIMENSIONS[kind], *_OPTIONAL.get(kind, ())}
    unknown = sorted(set(map(str, raw)) - allowed)
    if unknown:
        raise InputError(f"{where}: unknown field {unknown[0]!r} for a {kind}: expected "
                         f"{', '.join(sorted(allowed))}")
    dims: dict[str, Any] = {}
    for key in (*_DIMENSIONS[kind], *_OPTIONAL.get(kind, ())):
        if key not in raw:
            if key in _DIMENSIONS[kind]:
                raise InputError(f"{where}: a {kind} needs '{key}'")
            continue
        if key == "size":
            size = raw[key]
            if not isinstance(size, list | tuple) or len(size) != 3:
                raise InputError(f"{where}.size: expected [x, y, z] in metres, got {size!r}")
            dims[key] = tuple(_number(v, f"{where}.size") for v in size)
        else:
            dims[key] = _number(raw[key], f"{where}.{key}")
    fixed = bool(raw.get("fixed", kind == "faucet"))
    at = _pair(raw["at"], f"{where}.at") if "at" in raw else None
    if fixed and at is None:
        raise InputError(f"{where}: a fixed object needs 'at: [x, y]'")
    contents = None
    if raw.get("contents") is not None:
        c = raw["contents"]
        if kind not in ("cup", "bowl") or not isinstance(c, Mapping) or set(c) != {
                "material", "beads"}:
            raise InputError(f"{where}.contents: expected {{material: NAME, beads: N}} on a "
                             "cup or bowl")
        beads = c["beads"]
        if isinstance(beads, bool) or not isinstance(beads, int) or not 10 <= beads <= 400:
            raise InputError(f"{where}.contents.beads: expected an integer in [10, 400]")
        contents = Contents(str(c["material"]).lower(), beads)
    spec = ObjectSpec(name, kind, dims, fixed, at, contents)
    try:
        spec.geometry()
    except (ValueError, KeyError) as error:
        raise InputError(f"{where}: bad dimensions: {error}") from None
    return spec


def scene_from_world(world: Mapping[str, Any]) -> SceneSpec:
    """Parse and check a problem's ``world`` (raises :class:`InputError` naming the field)."""
    raw_objects = world.get("objects")
    if not isinstance(raw_objects, Mapping) or not raw_objects:
        raise InputError("world.objects: expected a mapping of object name to its shape")
    objects = {str(name).lower(): _object(str(name), raw) for name, raw in raw_objects.items()}
    raw_regions = world.get("regions", {}) or {}
    if not isinstance(raw_regions, Mapping):
        raise InputError("world.regions: expected a mapping of region name to [[x0, x1], [y0, y1]]")
    regions = {}
    for name, value in raw_regions.items():
        where = f"world.regions.{name}"
        if not isinstance(value, list | tuple) or len(value) != 2:
            raise InputError(f"{where}: expected [[x0, x1], [y0, y1]]")
        x, y = _pair(value[0], where), _pair(value[1], where)
        if x[0] >= x[1] or y[0] >= y[1]:
            raise InputError(f"{where}: each range must be [low, high] with low < high")
        regions[str(name).lower()] = Region(str(name).lower(), x, y)
    n_arms = world.get("arms", 1)
    if n_arms not in (1, 2):
        raise InputError(f"world.arms: expected 1 or 2, got {n_arms!r}")
    return SceneSpec(objects, regions, int(n_arms), _table(world.get("table")))


def _table(raw: Any) -> TableSpec:
    """``world.table``: ``{length, width}`` in metres (each in [0.5, 2.0]), or the default."""
    if raw is None:
        return TableSpec()
    if not isinstance(raw, Mapping) or not set(map(str, raw)) <= {"length", "width"}:
        raise InputError("world.table: expected {length: L, width: W} in metres")
    sizes = {}
    for key in ("length", "width"):
        value = _number(raw.get(key, getattr(TableSpec(), key)), f"world.table.{key}")
        if not 0.5 <= value <= 2.0:
            raise InputError(f"world.table.{key}: expected metres in [0.5, 2.0], got {value}")
        sizes[key] = value
    return TableSpec(length=sizes["length"], width=sizes["width"])
