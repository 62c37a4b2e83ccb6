"""Optional SAPIEN rendering, probed safely.

Creating SAPIEN's render system on a machine without a usable Vulkan device raises, and
some drivers crash the process outright. :func:`probe_render_device` therefore tries it in
a short-lived child interpreter first: a failure there (exception, crash or hang) becomes a
clear message and never takes the caller down. Only after a successful probe does
:class:`SapienCamera` create the render system in this process.
"""

from __future__ import annotations

import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.frames import AnimationInfo, GifTiming, write_animation
from ltamp_cli.backends.sapien.world import SapienWorld, sapien

_PROBE = (
    "import warnings\n"
    "warnings.simplefilter('ignore')\n"
    "import sapien\n"
    "sapien.render.RenderSystem()\n"
    "print('render-ok')\n"
)


class RendererUnavailable(RuntimeError):
    """SAPIEN has no rendering device here; the message says why and what to do."""


@dataclass(frozen=True)
class RenderProbe:
    """Outcome of :func:`probe_render_device`: ``available`` and, if not, ``reason``."""

    available: bool
    reason: str = ""


def probe_render_device(timeout_s: float = 60.0) -> RenderProbe:
    """Try to create a SAPIEN render system in a child process (a few seconds)."""
    try:
        done = subprocess.run(
            [sys.executable, "-c", _PROBE],
            capture_output=True,
            text=True,
            timeout=timeout_s,
            check=False,
        )
    except subprocess.TimeoutExpired:
        return RenderProbe(False, f"creating a render system did not finish in {timeout_s:g} s")
    if done.returncode == 0 and "render-ok" in done.stdout:
        return RenderProbe(True)
    lines = [line for line in done.stderr.strip().splitlines() if line.strip()]
    if done.returncode < 0:
        reason = f"creating a render system crashed (signal {-done.returncode})"
    else:
        reason = lines[-1] if lines else f"exit status {done.returncode}"
    return RenderProbe(False, reason)


def require_renderer(probe: RenderProbe) -> None:
    """Raise :class:`RendererUnavailable` with a one-line explanation if ``probe`` failed."""
    if not probe.available:
        raise RendererUnavailable(
            f"SAPIEN cannot render on this machine ({probe.reason}); physics still works: "
            "run without rendering, or render with --backend pybullet"
        )


def new_render_system() -> Any:
    """SAPIEN's render system; call only after a successful :func:`probe_render_device`."""
    return sapien.render.RenderSystem()


def look_at(eye: np.ndarray, target: np.ndarray) -> sapien.Pose:
    """Camera pose at ``eye`` ``(3,)`` looking at ``target`` ``(3,)`` (SAPIEN cameras look
    along their ``+x`` axis with ``+z`` up)."""
    forward = np.asarray(target, float) - np.asarray(eye, float)
    forward /= np.linalg.norm(forward)
    left = np.cross([0.0, 0.0, 1.0], forward)
    left /= np.linalg.norm(left)
    up = np.cross(forward, left)
    matrix = np.eye(4)
    matrix[:3, :3] = np.stack([forward, left, up], axis=1)
    matrix[:3, 3] = eye
    return sapien.Pose(matrix.astype(np.float32))


@dataclass(frozen=True)
class CameraView:
    """Where the camera is (``eye``, ``target`` in metres) and the image size in pixels."""

    eye: tuple[float, float, float] = (0.45, -0.45, 0.4)
    target: tuple[float, float, float] = (0.0, 0.0, 0.08)
    width: int = 640
    height: int = 480
    fovy_rad: float = 0.9


class SapienCamera:
    """A camera (and lights) added to a rendering :class:`SapienWorld`'s current scene."""

    def __init__(self, world: SapienWorld, view: CameraView | None = None) -> None:
        if not world.renders:
            raise RendererUnavailable("this SAPIEN world was built without a render system")
        self.view = view or CameraView()
        scene = world.scene
        scene.set_ambient_light([0.5, 0.5, 0.5])
        scene.add_directional_light([0.3, 0.6, -1.0], [0.6, 0.6, 0.6])
        self.component = sapien.render.RenderCameraComponent(self.view.width, self.view.height)
        self.component.set_fovy(self.view.fovy_rad)
        entity = sapien.Entity()
        entity.add_component(self.component)
        entity.set_pose(look_at(np.asarray(self.view.eye), np.asarray(self.view.target)))
        scene.add_entity(entity)
        self.scene = scene

    def rgb(self) -> np.ndarray:
        """The current image, ``(height, width, 3)`` uint8."""
        self.scene.update_render()
        self.component.take_picture()
        colour = np.asarray(self.component.get_picture("Color"))[..., :3]
        return (np.clip(colour, 0.0, 1.0) * 255).astype(np.uint8)


class FrameRecorder:
    """A step callback that keeps an RGB frame every ``every`` steps.

    Skills reset the world (a new scene) before stepping, so the camera is (re)attached to
    whatever scene the world holds at the first step after a reset. :attr:`caption` (the
    running action) is kept with every frame, as is the simulated time; :attr:`focus` is
    accepted for the recorders' common interface (SAPIEN's camera draws no inset).
    """

    def __init__(self, world: SapienWorld, every: int = 8, view: CameraView | None = None,
                 *, seconds_per_step: float = 1.0 / 240.0):
        if every < 1:
            raise ValueError("every must be >= 1")
        self.world, self.every, self.view = world, every, view
        self.seconds_per_step = seconds_per_step
        self.caption = ""
        self.focus: str | None = None
        self.frames: list[np.ndarray] = []
        self.times: list[float] = []
        self.captions: list[str] = []
        self._camera: SapienCamera | None = None

    def __call__(self, step: int) -> None:
        if self._camera is None or self._camera.scene is not self.world.scene:
            self._camera = SapienCamera(self.world, self.view)
        if step % self.every == 0:
            self.frames.append(self._camera.rgb())
            self.times.append(step * self.seconds_per_step)
            self.captions.append(self.caption)

    def save(self, path: str | Path, timing: GifTiming | None = None) -> AnimationInfo:
        """Write the recording (see :func:`~ltamp_cli.backends.frames.write_animation`)."""
        return write_animation(self.frames, self.times, self.captions, path, timing)


__all__ = [
    "CameraView",
    "FrameRecorder",
    "RenderProbe",
    "RendererUnavailable",
    "SapienCamera",
    "look_at",
    "new_render_system",
    "probe_render_device",
    "require_renderer",
]
