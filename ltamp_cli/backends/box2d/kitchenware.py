"""Cups, spoon, stirrer and blocks: their shapes and how they are added to a kitchen.

Every object is one Box2D body made of box fixtures (see :mod:`.geometry`); its origin is
the centre of its bottom, so placing a cup "on the table at x" means origin ``(x, top)``.
"""

from __future__ import annotations

from dataclasses import dataclass

from Box2D import b2

from ltamp_cli.backends.box2d.geometry import Box
from ltamp_cli.backends.box2d.world import Kitchen

Pose = tuple[float, float, float]


@dataclass(frozen=True)
class CupSpec:
    """An open-top cup with an L-shaped handle on its left (world units).

    ``width``/``height`` are the outer sizes of the cup proper. The handle is a vertical
    bar of ``handle_width`` standing ``handle_gap`` left of the cup on an arm along the
    bottom, so the gripper pinches the bar from above and never covers the cup's mouth.
    """

    width: float
    height: float
    wall: float = 0.2
    handle_gap: float = 0.5
    handle_width: float = 0.2

    @property
    def handle_x(self) -> float:
        """x of the handle bar's axis in the cup frame (origin: centre of the bottom)."""
        return -self.width / 2 - self.handle_gap - self.handle_width / 2

    @property
    def inner_width(self) -> float:
        return self.width - 2 * self.wall

    @property
    def inner_height(self) -> float:
        return self.height - self.wall

    def boxes(self) -> tuple[Box, ...]:
        w, h, t = self.width / 2, self.height, self.wall
        arm_hw = (self.handle_gap + self.handle_width) / 2
        return (
            Box(0.0, t / 2, w, t / 2),
            Box(-w + t / 2, h / 2, t / 2, h / 2),
            Box(w - t / 2, h / 2, t / 2, h / 2),
            Box(-w - arm_hw, t / 2, arm_hw, t / 2),
            Box(self.handle_x, h / 2, self.handle_width / 2, h / 2),
        )

    def grasp_height(self, ratio: float, clearance: float = 0.35) -> float:
        """Height of a grasp on the handle bar for ``ratio`` in [0, 1], above the arm."""
        low = self.wall + clearance
        return low + min(max(ratio, 0.0), 1.0) * (self.height - low)


@dataclass(frozen=True)
class SpoonSpec:
    """A spoon: a small open-top bowl with a vertical handle rising from its left wall.

    ``bowl_width``/``bowl_depth`` are outer sizes; the handle is ``handle_length`` long.
    """

    bowl_width: float = 1.6
    bowl_depth: float = 0.7
    wall: float = 0.1
    handle_length: float = 6.0

    @property
    def inner_width(self) -> float:
        return self.bowl_width - 2 * self.wall

    @property
    def inner_depth(self) -> float:
        return self.bowl_depth - self.wall

    @property
    def handle_x(self) -> float:
        """x of the handle's axis in the spoon frame."""
        return -self.bowl_width / 2 + self.wall / 2

    def boxes(self) -> tuple[Box, ...]:
        w, d, t = self.bowl_width / 2, self.bowl_depth, self.wall
        return (
            Box(0.0, t / 2, w, t / 2),
            Box(self.handle_x, (d + self.handle_length) / 2, t / 2, (d + self.handle_length) / 2),
            Box(w - t / 2, d / 2, t / 2, d / 2),
        )


@dataclass(frozen=True)
class StirrerSpec:
    """A stirrer: a thin rod of ``length`` with a paddle at its bottom."""

    length: float = 6.0
    thickness: float = 0.15
    paddle_width: float = 0.8

    def boxes(self) -> tuple[Box, ...]:
        t = self.thickness / 2
        return (
            Box(0.0, t, self.paddle_width / 2, t),
            Box(0.0, self.length / 2, t, self.length / 2),
        )


@dataclass(frozen=True)
class BlockSpec:
    """A square block seen from above (push skill): side ``size``, slides with damping."""

    size: float = 1.0
    density: float = 1.0
    linear_damping: float = 2.0
    angular_damping: float = 2.0

    def boxes(self) -> tuple[Box, ...]:
        return (Box(0.0, 0.0, self.size / 2, self.size / 2),)


def add_body(
    kitchen: Kitchen,
    boxes: tuple[Box, ...],
    pose: Pose,
    *,
    name: str,
    kind: str = "dynamic",
    density: float = 1.0,
    friction: float = 0.5,
    color: tuple[int, int, int] = (90, 140, 220),
) -> b2.body:
    """Add a body made of ``boxes`` at ``pose = (x, y, angle)``; ``kind`` is a Box2D type."""
    x, y, angle = pose
    create = {
        "dynamic": kitchen.world.CreateDynamicBody,
        "kinematic": kitchen.world.CreateKinematicBody,
        "static": kitchen.world.CreateStaticBody,
    }[kind]
    body = create(position=(x, y), angle=angle)
    for box in boxes:
        body.CreatePolygonFixture(
            box=(box.hw, box.hh, (box.cx, box.cy), 0.0), density=density, friction=friction
        )
    body.userData = {"name": name, "color": color}
    return body


def add_cup(
    kitchen: Kitchen, spec: CupSpec, pose: Pose, *, name: str = "cup", kind: str = "dynamic"
) -> b2.body:
    # Heavy walls: particles (density 0.01) must not be able to shove a cup around.
    return add_body(kitchen, spec.boxes(), pose, name=name, kind=kind, density=5.0)


def add_spoon(kitchen: Kitchen, spec: SpoonSpec, pose: Pose, *, kind: str = "dynamic") -> b2.body:
    return add_body(
        kitchen, spec.boxes(), pose, name="spoon", kind=kind, density=2.0, color=(120, 120, 120)
    )


def add_stirrer(
    kitchen: Kitchen, spec: StirrerSpec, pose: Pose, *, kind: str = "dynamic"
) -> b2.body:
    return add_body(
        kitchen, spec.boxes(), pose, name="stirrer", kind=kind, density=2.0, color=(60, 60, 60)
    )
