"""A software replay renderer for kitchen3d executions (no render device needed).

SAPIEN's own renderer needs a Vulkan device; PyBullet's renders on the CPU but slowly
(about 0.3 s for a 640×480 picture). So the execution records, every few
simulation steps, the *state* of every actor (each arm's joint positions and finger
opening, each kitchenware object's pose, each bead's position) as a :class:`ReplayFrame`.
:class:`ReplayRenderer` then rebuilds the scene once as a *mirror* in a PyBullet ``DIRECT``
client (the same Panda URDF and table as planning, the same kitchenware meshes, spheres for
beads; visual shapes only, never stepped), sets each recorded state and takes a picture
with PyBullet's TinyRenderer, which runs on the CPU. Recording costs microseconds a frame;
the rendering happens once, after the execution, so it never disturbs the physics, and
:meth:`ReplayRecorder.save` renders only the frames the GIF keeps (captioned, with the
camera following the arms and kitchenware, see
:class:`~ltamp_cli.backends.pybullet.render.Director`).

Poses: positions ``(3,)`` in metres, quaternions ``(4,)`` in ``(x, y, z, w)`` order.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import closing, contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pybullet as p

from ltamp_cli.backends.frames import AnimationInfo, GifTiming, write_animation
from ltamp_cli.backends.kitchenware_geometry import KitchenwareGeometry
from ltamp_cli.backends.pybullet.kitchenware import (
    BodyMaterial,
    KitchenwareBody,
    create_kitchenware,
)
from ltamp_cli.backends.pybullet.render import Camera, Director, render_rgb
from ltamp_cli.backends.pybullet.robot.scene import TableSpec, build_kitchen_scene

#: Display colours by kitchenware kind (the PyBullet executor's), RGBA in [0, 1].
KIND_RGBA: Mapping[str, tuple[float, float, float, float]] = {
    "cup": (0.9, 0.5, 0.2, 1.0),
    "bowl": (0.85, 0.85, 0.8, 1.0),
    "block": (0.3, 0.6, 0.3, 1.0),
    "faucet": (0.6, 0.6, 0.65, 1.0),
}
OTHER_RGBA = (0.7, 0.7, 0.7, 1.0)

#: Display colours of bead materials, RGBA in [0, 1]; other materials take
#: :data:`OTHER_BEAD_RGBA` in turn. Distinct colours make mixing (a stir) visible.
MATERIAL_RGBA: Mapping[str, tuple[float, float, float, float]] = {
    "water": (0.2, 0.45, 0.95, 1.0),
    "coffee": (0.35, 0.2, 0.1, 1.0),
    "sugar": (0.97, 0.97, 0.97, 1.0),
    "cream": (1.0, 0.9, 0.6, 1.0),
    "milk": (0.95, 0.95, 1.0, 1.0),
    "soap": (0.6, 0.9, 0.4, 1.0),
}
OTHER_BEAD_RGBA = ((0.85, 0.2, 0.5, 1.0), (0.5, 0.3, 0.85, 1.0), (0.2, 0.75, 0.75, 1.0))


def bead_rgba(material: str, index: int) -> tuple[float, float, float, float]:
    """The display colour of ``material``, the ``index``-th material of a scene."""
    return MATERIAL_RGBA.get(material.lower(), OTHER_BEAD_RGBA[index % len(OTHER_BEAD_RGBA)])


#: Where a bead with a non-finite recorded position is drawn: far below the floor (hidden).
HIDDEN_POSITION = (0.0, 0.0, -10.0)


@dataclass(frozen=True)
class BeadGroup:
    """``count`` beads of ``radius`` m drawn in ``rgba``."""

    count: int
    radius: float
    rgba: tuple[float, float, float, float] = (0.2, 0.4, 0.9, 1.0)


@dataclass(frozen=True)
class ReplayScene:
    """What the mirror holds: ``n_arms`` Pandas on ``table`` (as in
    :func:`~ltamp_cli.backends.pybullet.robot.scene.build_kitchen_scene`), kitchenware
    ``objects`` by name (geometry in the object frame) and ``beads`` by material."""

    n_arms: int
    table: TableSpec
    objects: Mapping[str, KitchenwareGeometry] = field(default_factory=dict)
    beads: Mapping[str, BeadGroup] = field(default_factory=dict)


@dataclass(frozen=True)
class ReplayFrame:
    """The recorded state at one instant.

    ``arms``: per arm, joint positions ``(7,)`` rad and the finger opening (m);
    ``objects``: per object name, position ``(3,)`` and quaternion ``(4,)`` xyzw;
    ``beads``: per material, bead centres ``(n, 3)`` m.
    """

    arms: tuple[tuple[np.ndarray, float], ...]
    objects: Mapping[str, tuple[np.ndarray, np.ndarray]]
    beads: Mapping[str, np.ndarray]


class ReplayRenderer:
    """The mirror scene of a :class:`ReplayScene` in its own PyBullet ``DIRECT`` client.

    Build once, then :meth:`render` any number of frames; :meth:`close` disconnects the
    client (``contextlib.closing`` makes it a context manager). ``camera`` is fixed, or
    with ``follow`` gives the direction and image size of a camera that keeps the arms and
    the kitchenware in view.
    """

    def __init__(self, scene: ReplayScene, camera: Camera | None = None,
                 follow: bool = False) -> None:
        self.scene = scene
        self.camera = camera or Camera()
        self.client = p.connect(p.DIRECT)
        if self.client < 0:
            raise RuntimeError("could not connect to a PyBullet server for rendering")
        try:
            self._build()
        except BaseException:
            self.close()
            raise
        self.director = (Director(self.client, self.camera, self._subjects, self._arms)
                         if follow else None)

    def _arms(self) -> list[int]:
        return [arm.body_id for arm in self.kitchen.arms]

    def _subjects(self) -> list[int]:
        return self._arms() + [body.body for body in self.objects.values()]

    def _build(self) -> None:
        client = self.client
        self.kitchen = build_kitchen_scene(client, self.scene.n_arms, self.scene.table)
        self.objects: dict[str, KitchenwareBody] = {
            name: create_kitchenware(
                client, geometry, material=BodyMaterial(
                    mass=0.0, rgba=KIND_RGBA.get(geometry.kind, OTHER_RGBA)
                ),
            )
            for name, geometry in self.scene.objects.items()
        }
        self.beads: dict[str, list[int]] = {}
        for material, group in self.scene.beads.items():
            visual = p.createVisualShape(
                p.GEOM_SPHERE, radius=group.radius, rgbaColor=list(group.rgba),
                physicsClientId=client,
            )
            # Visual-only bodies: nothing here is ever simulated.
            self.beads[material] = [
                p.createMultiBody(0.0, -1, visual, list(HIDDEN_POSITION), physicsClientId=client)
                for _ in range(group.count)
            ]

    def pose(self, frame: ReplayFrame) -> None:
        """Put every mirrored actor where ``frame`` recorded it."""
        if len(frame.arms) != len(self.kitchen.arms):
            raise ValueError(
                f"frame has {len(frame.arms)} arms, the scene {len(self.kitchen.arms)}"
            )
        for arm, (q, opening) in zip(self.kitchen.arms, frame.arms, strict=True):
            arm.set_configuration(np.asarray(q, dtype=float))
            arm.set_finger_opening(float(opening))
        for name, (position, quaternion) in frame.objects.items():
            self.objects[name].set_pose(np.asarray(position, float), np.asarray(quaternion, float))
        for material, positions in frame.beads.items():
            ids = self.beads[material]
            centres = np.asarray(positions, dtype=float).reshape(-1, 3)
            if len(centres) != len(ids):
                raise ValueError(
                    f"frame has {len(centres)} {material} beads, the scene {len(ids)}"
                )
            for body, centre in zip(ids, centres, strict=True):
                where = centre.tolist() if np.all(np.isfinite(centre)) else list(HIDDEN_POSITION)
                p.resetBasePositionAndOrientation(
                    body, where, (0.0, 0.0, 0.0, 1.0), physicsClientId=self.client
                )

    def render(self, frame: ReplayFrame, focus: str | None = None) -> np.ndarray:
        """The image of ``frame``: ``(camera.height, camera.width, 3)`` uint8; following,
        with a top view into the object named ``focus`` if given."""
        self.pose(frame)
        if self.director is None:
            return render_rgb(self.client, self.camera)
        return self.director.shoot(
            None if focus is None else self.objects[focus].body, focus or "")

    def close(self) -> None:
        if self.client >= 0:
            p.disconnect(physicsClientId=self.client)
            self.client = -1


def render_replay(
    scene: ReplayScene, frames: Sequence[ReplayFrame], camera: Camera | None = None
) -> list[np.ndarray]:
    """Render every recorded frame; ``len(frames)`` images ``(h, w, 3)`` uint8."""
    with closing(ReplayRenderer(scene, camera)) as renderer:
        return [renderer.render(frame) for frame in frames]


class ReplayRecorder:
    """A step callback that records a :class:`ReplayFrame` every ``every`` steps.

    ``snapshot`` reads the live simulation's state. :attr:`frames` renders the recording
    (once; later reads reuse the images), so it has the same interface as the camera
    recorders (``recorder(step)`` while simulating, ``recorder.frames`` afterwards);
    :meth:`save` renders only what the GIF shows. :attr:`caption` and :attr:`focus` (an
    object name to inset a top view of) are kept with each state, as is the time.
    """

    def __init__(
        self,
        scene: ReplayScene,
        snapshot: Callable[[], ReplayFrame],
        every: int = 8,
        camera: Camera | None = None,
        *,
        seconds_per_step: float = 1.0 / 240.0,
        follow: bool = False,
    ) -> None:
        if every < 1:
            raise ValueError("every must be at least 1")
        self.scene, self.snapshot, self.every = scene, snapshot, every
        self.camera = camera or Camera()
        self.seconds_per_step, self.follow = seconds_per_step, follow
        self.caption = ""
        self.focus: str | None = None
        self.recorded: list[ReplayFrame] = []
        self.times: list[float] = []
        self.captions: list[str] = []
        self.focuses: list[str | None] = []
        self._images: list[np.ndarray] | None = None

    def __call__(self, step: int) -> None:
        if step % self.every == 0:
            self.recorded.append(self.snapshot())
            self.times.append(step * self.seconds_per_step)
            self.captions.append(self.caption)
            self.focuses.append(self.focus)
            self._images = None

    @contextmanager
    def _rendered(self) -> Iterator[Sequence[np.ndarray]]:
        """The recording as a sequence that renders a frame when it is indexed."""
        with closing(ReplayRenderer(self.scene, self.camera, self.follow)) as renderer:
            yield _LazyFrames(renderer, self.recorded, self.focuses)

    @property
    def frames(self) -> list[np.ndarray]:
        """The recorded frames as images ``(h, w, 3)`` uint8, rendered on first access."""
        if self._images is None:
            with self._rendered() as lazy:
                self._images = [lazy[i] for i in range(len(lazy))]
        return self._images

    def save(self, path: str | Path, timing: GifTiming | None = None) -> AnimationInfo:
        """Write the recording (see :func:`~ltamp_cli.backends.frames.write_animation`),
        rendering only the frames it keeps."""
        with self._rendered() as lazy:
            return write_animation(lazy, self.times, self.captions, path, timing)


class _LazyFrames(Sequence[np.ndarray]):
    """Recorded states rendered on indexing (in order, so a following camera glides)."""

    def __init__(self, renderer: ReplayRenderer, states: Sequence[ReplayFrame],
                 focuses: Sequence[str | None]) -> None:
        self.renderer, self.states, self.focuses = renderer, states, focuses

    def __len__(self) -> int:
        return len(self.states)

    def __getitem__(self, index):  # type: ignore[no-untyped-def, override]
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        return self.renderer.render(self.states[index], self.focuses[index])


__all__ = [
    "KIND_RGBA",
    "MATERIAL_RGBA",
    "BeadGroup",
    "ReplayFrame",
    "ReplayRecorder",
    "ReplayRenderer",
    "ReplayScene",
    "bead_rgba",
    "render_replay",
]
