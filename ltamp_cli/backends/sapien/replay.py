"""A software replay renderer for kitchen3d executions on machines without a render device.

SAPIEN's own renderer needs a Vulkan device. Without one, the execution records, every few
simulation steps, the *state* of every actor (each arm's joint positions and finger
opening, each kitchenware object's pose, each bead's position) as a :class:`ReplayFrame`.
:class:`ReplayRenderer` then rebuilds the scene once as a *mirror* in a PyBullet ``DIRECT``
client (the same Panda URDF and table as planning, the same kitchenware meshes, spheres for
beads; visual shapes only, never stepped), sets each recorded state and takes a picture
with PyBullet's TinyRenderer, which runs on the CPU. Recording costs microseconds a frame;
the rendering happens once, after the execution, so it never disturbs the physics.

Poses: positions ``(3,)`` in metres, quaternions ``(4,)`` in ``(x, y, z, w)`` order.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from contextlib import closing
from dataclasses import dataclass, field

import numpy as np
import pybullet as p

from ltamp_cli.backends.kitchenware_geometry import KitchenwareGeometry
from ltamp_cli.backends.pybullet.kitchenware import (
    BodyMaterial,
    KitchenwareBody,
    create_kitchenware,
)
from ltamp_cli.backends.pybullet.render import Camera, render_rgb
from ltamp_cli.backends.pybullet.robot.scene import TableSpec, build_kitchen_scene

#: Display colours by kitchenware kind (the PyBullet executor's), RGBA in [0, 1].
KIND_RGBA: Mapping[str, tuple[float, float, float, float]] = {
    "cup": (0.9, 0.5, 0.2, 1.0),
    "bowl": (0.85, 0.85, 0.8, 1.0),
    "block": (0.3, 0.6, 0.3, 1.0),
    "faucet": (0.6, 0.6, 0.65, 1.0),
}
OTHER_RGBA = (0.7, 0.7, 0.7, 1.0)

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
    client (``contextlib.closing`` makes it a context manager).
    """

    def __init__(self, scene: ReplayScene, camera: Camera | None = None) -> None:
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

    def render(self, frame: ReplayFrame) -> np.ndarray:
        """The image of ``frame``: ``(camera.height, camera.width, 3)`` uint8."""
        self.pose(frame)
        return render_rgb(self.client, self.camera)

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
    recorders (``recorder(step)`` while simulating, ``recorder.frames`` afterwards).
    """

    def __init__(
        self,
        scene: ReplayScene,
        snapshot: Callable[[], ReplayFrame],
        every: int = 8,
        camera: Camera | None = None,
    ) -> None:
        if every < 1:
            raise ValueError("every must be at least 1")
        self.scene, self.snapshot, self.every = scene, snapshot, every
        self.camera = camera or Camera()
        self.recorded: list[ReplayFrame] = []
        self._images: list[np.ndarray] | None = None

    def __call__(self, step: int) -> None:
        if step % self.every == 0:
            self.recorded.append(self.snapshot())
            self._images = None

    @property
    def frames(self) -> list[np.ndarray]:
        """The recorded frames as images ``(h, w, 3)`` uint8, rendered on first access."""
        if self._images is None:
            self._images = render_replay(self.scene, self.recorded, self.camera)
        return self._images


__all__ = [
    "KIND_RGBA",
    "BeadGroup",
    "ReplayFrame",
    "ReplayRecorder",
    "ReplayRenderer",
    "ReplayScene",
    "render_replay",
]
