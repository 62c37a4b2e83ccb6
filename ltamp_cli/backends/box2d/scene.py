"""Kitchen scenes for planning problems: which objects stand where, seeded by the problem.

A planning problem's ``world:`` mapping (YAML) describes the movable objects and the
arrangement rules; :func:`scene_from_world` turns it into a frozen :class:`SceneSpec` with
concrete sizes and home positions drawn from a seeded generator, and :func:`build_scene`
makes the live Box2D kitchen for it (used by the plan executor). The same
``(world, seed)`` always gives the same scene, which is how the executor reconstructs the
arrangement the planner saw.

``world`` keys (lengths in world units, the table top is at ``layout.table_top``)::

    objects:                  # name -> description (order = PDDL object names)
      cup:    {kind: cup, width: [3.8, 4.4], height: [3.0, 3.4]}      # [lo, hi] or a number
      cream:  {kind: cup, width: 3.4, height: 3.2, material: cream}    # filled cup (pour)
      sugar:  {kind: bowl, width: 6.5, height: 4.5, material: sugar}   # scoop source
      spoon:  {kind: spoon}
      stirrer: {kind: stirrer}
      block:  {kind: block, size: 1.0}
    storage: [-14.0, 11.0]    # x range where objects' homes are packed (shuffled by seed)
    faucet: {material: coffee, particles: 150}
    fixed: {sugar: 0.0}       # optional: home x of some objects (not shuffled)
    walls: [[x, width, height], ...]   # optional static obstacles standing on the table
    curbs: {block: {side: either, height: 0.25, width: 0.6, gap: 0.1}}   # optional
    holders: {pitcher: {height: 1.6}}  # optional: a fixed U-shaped holder around a cup

A *curb* is a low static wall standing ``gap`` beside an object (``side``: ``left``,
``right`` or ``either``, drawn by the seed), too close for a finger but low enough for a
pusher to pass over. A *holder* is a fixed U (base plate in the table, a wall on each side)
hugging a cup and its handle: fingers can only take the handle above its walls.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from Box2D import b2

from ltamp_cli.backends.box2d.faucet import Faucet, FaucetSpec
from ltamp_cli.backends.box2d.geometry import Box
from ltamp_cli.backends.box2d.gripper import Gripper, GripperSpec
from ltamp_cli.backends.box2d.kitchenware import (
    BlockSpec,
    CupSpec,
    SpoonSpec,
    StirrerSpec,
    add_body,
    add_cup,
    add_spoon,
    add_stirrer,
)
from ltamp_cli.backends.box2d.particles import ParticleSpec, add_particles, hex_grid
from ltamp_cli.backends.box2d.skills import pour as pour_skill
from ltamp_cli.backends.box2d.skills import scoop as scoop_skill
from ltamp_cli.backends.box2d.world import Kitchen, KitchenLayout, Observer
from ltamp_cli.errors import InputError

KINDS = ("cup", "bowl", "spoon", "stirrer", "block")

#: Particle materials: radius and colour. Pour-sized grains for liquids, scoop-sized for
#: sugar, so that the learned models see the particles they were trained on.
MATERIALS: Mapping[str, ParticleSpec] = {
    "coffee": ParticleSpec(color=(110, 60, 25), material="coffee"),
    "cream": ParticleSpec(color=(235, 225, 200), material="cream"),
    "water": ParticleSpec(color=(40, 90, 230), material="water"),
    "sugar": ParticleSpec(radius=0.1, color=(250, 140, 190), material="sugar"),
}

#: Grains in a filled cup unless its ``particles`` says otherwise (the kitchen's count; the
#: pour skill's trials use fewer, see ``bench/fidelity.py`` for why that does not matter).
CUP_PARTICLES = 200
#: Clearance kept around every object's footprint (the fingers need room beside handles).
CLEARANCE = 0.7
#: A holder's walls: thickness, and their gaps to the handle bar (left; narrower than a
#: finger) and to the cup's right wall.
HOLDER_WALL = 0.3
HOLDER_LEFT_GAP = 0.2
HOLDER_RIGHT_GAP = 0.15


@dataclass(frozen=True)
class Holder:
    """A fixed U-shaped holder around object ``name``: walls ``[x0, x1]`` (left, right) of
    ``height`` standing on the table; the base plate lies in the table top between them."""

    name: str
    left: tuple[float, float]
    right: tuple[float, float]
    height: float

    def walls(self) -> tuple[tuple[float, float], tuple[float, float]]:
        return (self.left, self.right)


@dataclass(frozen=True)
class SceneObject:
    """One movable object with concrete sizes; ``home`` is the x of its origin on the table.

    ``spec`` is a :class:`CupSpec` (cups and bowls), :class:`SpoonSpec`,
    :class:`StirrerSpec` or :class:`BlockSpec`; ``material``/``n_particles`` describe what
    it holds at the start (nothing when ``material`` is empty).
    """

    name: str
    kind: str
    spec: Any
    home: float
    material: str = ""
    n_particles: int = 0

    def boxes(self) -> tuple[Box, ...]:
        return self.spec.boxes()

    def extent(self) -> tuple[float, float, float]:
        """``(left, right, top)`` of the object's boxes in its frame (origin: bottom centre)."""
        boxes = self.boxes()
        return (
            min(b.cx - b.hw for b in boxes),
            max(b.cx + b.hw for b in boxes),
            max(b.cy + b.hh for b in boxes),
        )


@dataclass(frozen=True)
class SceneSpec:
    """A concrete kitchen: layout, objects (with homes), faucet and static walls."""

    objects: tuple[SceneObject, ...]
    layout: KitchenLayout = field(default_factory=KitchenLayout)
    faucet_material: str = "coffee"
    faucet_particles: int = 150
    walls: tuple[tuple[float, float, float], ...] = ()
    gripper: GripperSpec = field(default_factory=GripperSpec)
    holders: tuple[Holder, ...] = ()

    def object(self, name: str) -> SceneObject:
        for item in self.objects:
            if item.name == name:
                return item
        raise KeyError(f"no object {name!r} in the scene")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(item.name for item in self.objects)


def _number(value: Any, where: str, rng: np.random.Generator) -> float:
    """A number, or ``[lo, hi]`` drawn uniformly (one draw either way keeps streams aligned)."""
    draw = float(rng.uniform())
    if isinstance(value, int | float) and not isinstance(value, bool):
        return float(value)
    if (
        isinstance(value, list | tuple)
        and len(value) == 2
        and all(isinstance(v, int | float) for v in value)
        and value[0] <= value[1]
    ):
        return float(value[0]) + draw * (float(value[1]) - float(value[0]))
    raise InputError(f"world: {where}: expected a number or [low, high], got {value!r}")


def _make_object(name: str, raw: Any, rng: np.random.Generator) -> SceneObject:
    if not isinstance(raw, Mapping):
        raise InputError(f"world: objects.{name}: expected a mapping with a 'kind'")
    kind = raw.get("kind")
    if kind not in KINDS:
        raise InputError(f"world: objects.{name}.kind: expected one of {', '.join(KINDS)}, "
                         f"got {kind!r}")
    material = str(raw.get("material", ""))
    if material and material not in MATERIALS:
        raise InputError(f"world: objects.{name}.material: expected one of "
                         f"{', '.join(MATERIALS)}, got {material!r}")
    where = f"objects.{name}"
    spec: Any
    n = 0
    if kind in ("cup", "bowl"):
        width = _number(raw.get("width", 4.0), f"{where}.width", rng)
        height = _number(raw.get("height", 3.5), f"{where}.height", rng)
        if not (2.0 <= width <= 12.0 and 2.0 <= height <= 9.0):
            raise InputError(f"world: {where}: cup width must be in [2, 12] and height in "
                             f"[2, 9], got {width:g} x {height:g}")
        spec = CupSpec(width, height, pour_skill.PourConfig().wall)
        if material and kind == "cup":
            n = int(raw.get("particles", CUP_PARTICLES))
        elif material:
            n = scoop_skill.fill_count(spec, scoop_skill.ScoopConfig())
    elif kind == "spoon":
        spec = SpoonSpec()
    elif kind == "stirrer":
        spec = StirrerSpec()
    else:
        spec = BlockSpec(size=_number(raw.get("size", 1.0), f"{where}.size", rng))
    if n < 0:
        raise InputError(f"world: {where}.particles: expected a count >= 0")
    return SceneObject(name, str(kind), spec, 0.0, material, n)


def _layout(raw: Any) -> KitchenLayout:
    if not isinstance(raw, Mapping):
        raise InputError("world: 'layout' must map KitchenLayout fields to numbers")
    known = set(KitchenLayout.__dataclass_fields__)
    for key in raw:
        if key not in known:
            raise InputError(f"world: layout: unknown field {key!r}: expected one of "
                             f"{', '.join(sorted(known))}")
    return KitchenLayout(**{str(k): float(v) for k, v in raw.items()})


def scene_from_world(world: Mapping[str, Any], rng: np.random.Generator) -> SceneSpec:
    """Draw a concrete scene from a problem's ``world`` mapping (see the module docstring).

    Sizes given as ranges are drawn first, then the order of the objects along the storage
    range and the free space between them. Raises ``InputError`` on a malformed ``world``
    or when the objects do not fit in the storage range.
    """
    raw_objects = world.get("objects")
    if not isinstance(raw_objects, Mapping) or not raw_objects:
        raise InputError("world: 'objects' must map object names to descriptions")
    layout = _layout(world.get("layout", {}) or {})
    objects = [_make_object(str(name).lower(), raw, rng) for name, raw in raw_objects.items()]
    fixed_raw = world.get("fixed", {}) or {}
    if not isinstance(fixed_raw, Mapping):
        raise InputError("world: 'fixed' must map object names to home x positions")
    fixed = {str(k).lower(): float(v) for k, v in fixed_raw.items()}
    for name in fixed:
        if name not in {o.name for o in objects}:
            raise InputError(f"world: fixed: unknown object {name!r}")
    storage = world.get("storage", [-14.0, 11.0])
    if not (isinstance(storage, list | tuple) and len(storage) == 2 and storage[0] < storage[1]):
        raise InputError(f"world: storage: expected [x_low, x_high], got {storage!r}")
    lo, hi = float(storage[0]), float(storage[1])

    free = [o for o in objects if o.name not in fixed]
    order = rng.permutation(len(free))
    widths = []
    for index in order:
        left, right, _ = free[index].extent()
        widths.append(right - left + 2 * CLEARANCE)
    slack = (hi - lo) - sum(widths)
    if slack < 0:
        raise InputError(f"world: the objects need {sum(widths):.1f} units of storage but "
                         f"storage [{lo:g}, {hi:g}] has {hi - lo:.1f}")
    gaps = rng.dirichlet(np.ones(len(free) + 1)) * slack
    homes: dict[str, float] = dict(fixed)
    x = lo
    for k, index in enumerate(order):
        x += gaps[k]
        left, _, _ = free[index].extent()
        homes[free[index].name] = round(x + CLEARANCE - left, 4)
        x += widths[k]
    placed = tuple(
        SceneObject(o.name, o.kind, o.spec, homes[o.name], o.material, o.n_particles)
        for o in objects
    )
    faucet = world.get("faucet", {}) or {}
    material = str(faucet.get("material", "coffee"))
    if material not in MATERIALS:
        raise InputError(f"world: faucet.material: expected one of {', '.join(MATERIALS)}")
    walls = tuple(tuple(float(v) for v in wall) for wall in world.get("walls", []) or [])
    if any(len(w) != 3 for w in walls):
        raise InputError("world: walls: expected a list of [x, width, height]")
    # Curbs and holders come last so that problems without them keep their draws.
    by_name = {o.name: o for o in placed}
    walls += _curbs(world.get("curbs", {}) or {}, by_name, rng)
    holders = _holders(world.get("holders", {}) or {}, by_name)
    return SceneSpec(
        placed,
        layout,
        material,
        int(faucet.get("particles", 150)),
        walls,  # type: ignore[arg-type]
        holders=holders,
    )


def _known(raw: Any, key: str, objects: Mapping[str, SceneObject]) -> Mapping[str, Any]:
    if not isinstance(raw, Mapping):
        raise InputError(f"world: {key}: expected a mapping of object names to settings")
    for name, entry in raw.items():
        if str(name).lower() not in objects:
            raise InputError(f"world: {key}: unknown object {name!r}")
        if not isinstance(entry, Mapping):
            raise InputError(f"world: {key}.{name}: expected a mapping")
    return raw


def _curbs(raw: Any, objects: Mapping[str, SceneObject], rng: np.random.Generator
           ) -> tuple[tuple[float, float, float], ...]:
    """Walls ``(x, width, height)`` of the curbs beside objects (one draw per curb)."""
    out = []
    for name, entry in _known(raw, "curbs", objects).items():
        item = objects[str(name).lower()]
        where = f"curbs.{name}"
        side = str(entry.get("side", "either"))
        if side not in ("left", "right", "either"):
            raise InputError(f"world: {where}.side: expected left, right or either, "
                             f"got {side!r}")
        draw = float(rng.uniform())
        if side == "either":
            side = "left" if draw < 0.5 else "right"
        height = _number(entry.get("height", 0.25), f"{where}.height", rng)
        width = _number(entry.get("width", 0.6), f"{where}.width", rng)
        gap = _number(entry.get("gap", 0.1), f"{where}.gap", rng)
        if not (height > 0 and width > 0 and gap >= 0):
            raise InputError(f"world: {where}: expected height, width > 0 and gap >= 0")
        left, right, _ = item.extent()
        x = (item.home + right + gap + width / 2 if side == "right"
             else item.home + left - gap - width / 2)
        out.append((round(x, 4), width, height))
    return tuple(out)


def _holders(raw: Any, objects: Mapping[str, SceneObject]) -> tuple[Holder, ...]:
    out = []
    for name, entry in _known(raw, "holders", objects).items():
        item = objects[str(name).lower()]
        if item.kind != "cup":
            raise InputError(f"world: holders.{name}: only cups stand in holders")
        height = entry.get("height", 1.6)
        if isinstance(height, bool) or not isinstance(height, int | float) or not (
                0.3 <= height <= item.spec.height - 0.5):
            raise InputError(f"world: holders.{name}.height: expected a number in [0.3, "
                             f"{item.spec.height - 0.5:.2f}] (below the cup's rim)")
        spec = item.spec
        bar_left = item.home + spec.handle_x - spec.handle_width / 2
        cup_right = item.home + spec.width / 2
        left = bar_left - HOLDER_LEFT_GAP
        right = cup_right + HOLDER_RIGHT_GAP
        out.append(Holder(item.name, (round(left - HOLDER_WALL, 4), round(left, 4)),
                          (round(right, 4), round(right + HOLDER_WALL, 4)), float(height)))
    return tuple(out)


@dataclass
class LiveScene:
    """A built kitchen: Box2D bodies by object name, the gripper and the faucet."""

    spec: SceneSpec
    kitchen: Kitchen
    bodies: dict[str, b2.body]
    gripper: Gripper
    faucet: Faucet

    def particles_of(self, material: str) -> list[b2.body]:
        return [p for p in self.kitchen.particles if p.userData.get("material") == material]


def object_top(spec: SceneSpec, surface: str) -> float:
    """Height of a surface objects stand on: ``table`` or ``coaster``."""
    lay = spec.layout
    return lay.table_top + (lay.coaster_height if surface == "coaster" else 0.0)


def build_scene(spec: SceneSpec, seed: int, observer: Observer | None = None) -> LiveScene:
    """Build the Box2D kitchen of ``spec``: objects at their homes, filled with particles.

    The gripper starts open, high above the middle of the table; the faucet starts off.
    """
    kitchen = Kitchen(layout=spec.layout)
    if observer is not None:
        kitchen.observers.append(observer)
    rng = np.random.default_rng(seed)
    top = spec.layout.table_top
    bodies: dict[str, b2.body] = {}
    # A floor under the table: grains that fall off the table stay in the world.
    floor = kitchen.world.CreateStaticBody(position=(0.0, 0.0))
    floor.CreatePolygonFixture(box=(spec.layout.width / 2, 0.5, (0.0, 0.5), 0.0))
    floor.userData = {"name": "floor", "color": (200, 200, 200)}
    for x, width, height in spec.walls:
        wall = kitchen.world.CreateStaticBody(position=(x, top))
        wall.CreatePolygonFixture(box=(width / 2, height / 2, (0.0, height / 2), 0.0))
        wall.userData = {"name": "wall", "color": (120, 120, 120)}
    for holder in spec.holders:
        # One static U: the base plate lies in the table top (the cup stands on the table).
        (a0, a1), (b0, b1) = holder.walls()
        body = kitchen.world.CreateStaticBody(position=(0.0, top))
        for x0, x1, y0, y1 in ((a0, a1, 0.0, holder.height), (b0, b1, 0.0, holder.height),
                               (a0, b1, -0.2, 0.0)):
            fixture = body.CreatePolygonFixture(box=((x1 - x0) / 2, (y1 - y0) / 2,
                                                     ((x0 + x1) / 2, (y0 + y1) / 2), 0.0))
            # The base is part of the table top: the cup stands on it (not an obstacle).
            fixture.userData = {"part": "base" if y1 <= 0.0 else "wall"}
        body.userData = {"name": "holder", "color": (95, 95, 140)}
    for item in spec.objects:
        pose = (item.home, top, 0.0)
        if item.kind in ("cup", "bowl"):
            body = add_cup(kitchen, item.spec, pose, name="cup")
        elif item.kind == "spoon":
            body = add_spoon(kitchen, item.spec, pose)
        elif item.kind == "stirrer":
            body = add_stirrer(kitchen, item.spec, pose)
        else:
            half = item.spec.size / 2
            body = add_body(kitchen, item.spec.boxes(), (item.home, top + half, 0.0),
                            name="block", color=(200, 80, 60))
        body.userData["object"] = item.name
        bodies[item.name] = body
        if item.material and item.n_particles > 0:
            material = MATERIALS[item.material]
            inner = item.spec.inner_width / 2
            points = hex_grid(item.home - inner, item.home + inner, top + item.spec.wall,
                              item.n_particles, material.radius, rng)
            add_particles(kitchen, points, material)
    lay = spec.layout
    faucet = Faucet(
        kitchen,
        FaucetSpec(lay.faucet_x, lay.faucet_y, capacity=spec.faucet_particles,
                   particle=MATERIALS[spec.faucet_material]),
    )
    faucet.enabled = False
    gripper = Gripper(kitchen, (0.0, top + 15.0, 0.0), 0.4, spec.gripper)
    kitchen.step(20)  # let everything come to rest before the first action
    return LiveScene(spec, kitchen, bodies, gripper, faucet)


def cup_grasp(spec: CupSpec, ratio: float) -> tuple[float, float]:
    """Gripper origin relative to a cup's origin for a handle grasp at ``ratio``."""
    return (round(spec.handle_x, 6), round(spec.grasp_height(ratio), 6))


def default_grasp(item: SceneObject) -> tuple[float, float]:
    """The engineered grasp of an object (gripper origin in the object's frame)."""
    if item.kind in ("cup", "bowl"):
        return cup_grasp(item.spec, 0.6)
    if item.kind == "spoon":
        return (round(item.spec.handle_x, 6),
                round(scoop_skill.grasp_height(scoop_skill.ScoopConfig(), 0.5), 6))
    if item.kind == "stirrer":
        return (0.0, round(item.spec.length - 1.5, 6))
    # A block is pinched at mid-height, the fingers beside it.
    return (0.0, round(item.spec.size / 2, 6))


def grasp_opening(item: SceneObject) -> float:
    """Finger opening when closed on the object's grasped bar (its thickness)."""
    if item.kind in ("cup", "bowl"):
        return item.spec.handle_width
    if item.kind == "spoon":
        return item.spec.wall
    if item.kind == "stirrer":
        return item.spec.thickness
    return item.spec.size


def describe(spec: SceneSpec) -> dict[str, Any]:
    """A JSON-able summary of the scene (sizes and homes), for reports."""
    out: dict[str, Any] = {}
    for item in spec.objects:
        entry: dict[str, Any] = {"kind": item.kind, "home": item.home}
        if item.kind in ("cup", "bowl"):
            entry.update(width=round(item.spec.width, 4), height=round(item.spec.height, 4))
        if item.material:
            entry.update(material=item.material, particles=item.n_particles)
        out[item.name] = entry
    return out


__all__ = [
    "MATERIALS",
    "Holder",
    "LiveScene",
    "SceneObject",
    "SceneSpec",
    "build_scene",
    "cup_grasp",
    "default_grasp",
    "describe",
    "grasp_opening",
    "object_top",
    "scene_from_world",
]
