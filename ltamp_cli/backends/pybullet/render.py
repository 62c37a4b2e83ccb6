"""CPU images of a PyBullet world with the TinyRenderer (works headless).

Besides fixed :class:`Camera` pictures, a :class:`Director` films an execution the way a
talk needs it: the camera keeps the robot arms and every named object (the carried cup
too) in the picture, re-framing smoothly only when something would leave it, and a
top-view inset looks into the container the current action works on (the stir or pour
happens inside an opaque cup). :class:`FrameRecorder` films with a fixed camera and keeps
the simulated time and a caption with each frame for
:func:`~ltamp_cli.backends.frames.write_animation`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pybullet as p

from ltamp_cli.backends.frames import (
    AnimationInfo,
    GifTiming,
    as_image,
    inset,
    write_animation,
)

#: Smallest camera distance (m) a framing uses, so a single small object is not filled in.
MIN_DISTANCE = 0.35


@dataclass(frozen=True)
class Camera:
    """A look-at camera: ``target`` (m), ``distance`` (m), ``yaw``/``pitch`` (degrees),
    image ``width`` × ``height`` pixels and vertical field of view ``fov`` (degrees)."""

    target: tuple[float, float, float] = (0.0, 0.0, 0.08)
    distance: float = 0.6
    yaw: float = 30.0
    pitch: float = -30.0
    width: int = 640
    height: int = 480
    fov: float = 50.0


def view_matrix(camera: Camera) -> list[float]:
    """PyBullet's (column-major 4×4) view matrix of ``camera`` (z up)."""
    return list(p.computeViewMatrixFromYawPitchRoll(
        list(camera.target), camera.distance, camera.yaw, camera.pitch, 0.0, 2))


def camera_axes(yaw: float, pitch: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit ``right``, ``up`` and ``forward`` (viewing direction) vectors ``(3,)`` of a
    camera with ``yaw``/``pitch`` in degrees, as PyBullet's view matrix defines them."""
    m = np.asarray(view_matrix(Camera(target=(0.0, 0.0, 0.0), distance=1.0, yaw=yaw,
                                      pitch=pitch)), dtype=float).reshape(4, 4)
    # Column-major: m[j, i] is row i, column j of the matrix; rows 0-2 hold the camera axes.
    return m[:3, 0], m[:3, 1], -m[:3, 2]


def half_extents(camera: Camera) -> tuple[float, float]:
    """``tan`` of half the horizontal and vertical fields of view of ``camera``."""
    ty = math.tan(math.radians(camera.fov) / 2)
    return ty * camera.width / camera.height, ty


def required_distance(camera: Camera, points: np.ndarray, margin: float,
                      min_distance: float = MIN_DISTANCE) -> float:
    """The smallest distance from ``camera.target`` (its direction kept), at least
    ``min_distance``, at which every point ``(n, 3)`` lies within ``margin`` (0-1] of the
    image's half-width/height."""
    right, up, forward = camera_axes(camera.yaw, camera.pitch)
    tx, ty = half_extents(camera)
    q = np.asarray(points, dtype=float).reshape(-1, 3) - np.asarray(camera.target)
    x, y, z = q @ right, q @ up, q @ forward
    return float(max(np.max(np.abs(x) / (tx * margin) - z), np.max(np.abs(y) / (ty * margin) - z),
                     min_distance))


def frame_points(points: np.ndarray, camera: Camera, margin: float = 0.85,
                 min_distance: float = MIN_DISTANCE) -> Camera:
    """``camera`` (same direction, size and field of view) moved to show every point
    ``(n, 3)`` m within ``margin`` of the image's half-width/height, centred on them, from
    at least ``min_distance`` m."""
    right, up, forward = camera_axes(camera.yaw, camera.pitch)
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    coords = pts @ np.stack([right, up, forward], axis=1)  # (n, 3) in camera axes
    middle = (coords.min(axis=0) + coords.max(axis=0)) / 2
    target = right * middle[0] + up * middle[1] + forward * middle[2]
    centred = replace(camera, target=tuple(float(v) for v in target))
    return replace(centred, distance=required_distance(centred, pts, margin, min_distance))


def body_points(client: int, bodies: Sequence[int]) -> np.ndarray:
    """The corners ``(8 · links, 3)`` m of every link's bounding box of ``bodies``."""
    corners = []
    for body in bodies:
        for link in range(-1, p.getNumJoints(body, physicsClientId=client)):
            low, high = p.getAABB(body, link, physicsClientId=client)
            low, high = np.asarray(low), np.asarray(high)
            corners += [np.where([i & 1, i & 2, i & 4], high, low) for i in range(8)]
    return np.asarray(corners, dtype=float).reshape(-1, 3)


class FollowCamera:
    """A camera that keeps a changing set of points in view without restless motion.

    It stays put while every point is within ``margin`` of the image and the points fill
    more than ``1 / zoom_out`` of it; otherwise it glides (a fraction ``glide`` of the way
    per frame) to a framing with ``slack`` room to spare, never letting a point drop out.
    """

    def __init__(self, base: Camera, margin: float = 0.9, slack: float = 1.2,
                 zoom_out: float = 1.8, glide: float = 0.35) -> None:
        self.base, self.margin, self.slack = base, margin, slack
        self.zoom_out, self.glide = zoom_out, glide
        self.current: Camera | None = None
        self.goal: Camera | None = None

    def update(self, points: np.ndarray) -> Camera:
        """The camera for a frame showing ``points`` ``(n, 3)`` m."""
        ideal = frame_points(points, self.base, self.margin / self.slack)
        if self.current is None:
            self.current = ideal
            return ideal
        need = required_distance(self.current, points, self.margin)
        if need > self.current.distance or need * self.zoom_out < self.current.distance:
            self.goal = ideal
        if self.goal is not None:
            a = self.glide
            target = tuple(float(c + a * (g - c)) for c, g in
                           zip(self.current.target, self.goal.target, strict=True))
            moved = replace(self.current, target=target,
                            distance=self.current.distance
                            + a * (self.goal.distance - self.current.distance))
            # Never lose a point on the way.
            fit = required_distance(moved, points, 1.0)
            self.current = replace(moved, distance=max(moved.distance, fit))
            if np.allclose(self.current.target, self.goal.target, atol=2e-3) and abs(
                    self.current.distance - self.goal.distance) < 2e-3:
                self.current, self.goal = self.goal, None
        return self.current


def render_rgb(client: int, camera: Camera | None = None) -> np.ndarray:
    """One RGB frame ``(height, width, 3)`` uint8 of the world in ``client``."""
    camera = camera or Camera()
    projection = p.computeProjectionMatrixFOV(
        camera.fov, camera.width / camera.height, 0.01, 8.0, physicsClientId=client
    )
    _, _, rgba, _, _ = p.getCameraImage(
        camera.width,
        camera.height,
        view_matrix(camera),
        projection,
        renderer=p.ER_TINY_RENDERER,
        physicsClientId=client,
    )
    image = np.asarray(rgba, dtype=np.uint8).reshape(camera.height, camera.width, 4)
    return image[..., :3].copy()


def top_view(camera: Camera, points: np.ndarray, scale: float = 0.3) -> Camera:
    """A camera looking straight down on ``points`` ``(n, 3)`` (a container), its image
    ``scale`` times ``camera``'s size, the container's top filling most of it."""
    small = replace(camera, width=max(16, round(camera.width * scale)),
                    height=max(12, round(camera.height * scale)), pitch=-89.0, fov=40.0)
    return frame_points(points, small, margin=0.9, min_distance=0.05)


class Director:
    """Films a PyBullet world: follows ``subjects()`` (body ids) with ``camera``'s direction
    and size, and insets a top view into ``focus`` (body id) when one is set.

    The bodies ``hide_in_inset()`` (the arms: a hand above the cup would fill the top view)
    are moved far away while the inset is taken and put back after, so use a Director only
    on a client that is not being simulated (a replay mirror).
    """

    def __init__(self, client: int, camera: Camera, subjects: Callable[[], Sequence[int]],
                 hide_in_inset: Callable[[], Sequence[int]] = tuple) -> None:
        self.client = client
        self.follow = FollowCamera(camera)
        self.subjects = subjects
        self.hide_in_inset = hide_in_inset

    def shoot(self, focus: int | None = None, focus_label: str = "") -> np.ndarray:
        """The current picture ``(height, width, 3)`` uint8."""
        camera = self.follow.update(body_points(self.client, self.subjects()))
        image = render_rgb(self.client, camera)
        if focus is None:
            return image
        top = top_view(camera, body_points(self.client, [focus]))
        hidden = [(body, p.getBasePositionAndOrientation(body, physicsClientId=self.client))
                  for body in self.hide_in_inset()]
        for body, _ in hidden:
            p.resetBasePositionAndOrientation(body, (0.0, 0.0, -50.0), (0.0, 0.0, 0.0, 1.0),
                                              physicsClientId=self.client)
        try:
            small = render_rgb(self.client, top)
        finally:
            for body, (position, orientation) in hidden:
                p.resetBasePositionAndOrientation(body, position, orientation,
                                                  physicsClientId=self.client)
        label = f"top view: {focus_label}" if focus_label else "top view"
        return np.asarray(inset(as_image(image), as_image(small), label))


class FrameRecorder:
    """A step callback that keeps one frame of ``camera`` every ``every`` simulation steps.

    Set :attr:`caption` (e.g. the running action): it is kept with every frame, as is the
    simulated time (``seconds_per_step``).
    """

    def __init__(self, client: int, every: int = 8, camera: Camera | None = None, *,
                 seconds_per_step: float = 1.0 / 240.0) -> None:
        if every < 1:
            raise ValueError("every must be at least 1")
        self.client = client
        self.every = every
        self.camera = camera or Camera()
        self.seconds_per_step = seconds_per_step
        self.caption = ""
        self.frames: list[np.ndarray] = []
        self.times: list[float] = []
        self.captions: list[str] = []

    def __call__(self, step: int) -> None:
        if step % self.every:
            return
        self.frames.append(render_rgb(self.client, self.camera))
        self.times.append(step * self.seconds_per_step)
        self.captions.append(self.caption)

    def save(self, path: str | Path, timing: GifTiming | None = None) -> AnimationInfo:
        """Write the recording (see :func:`~ltamp_cli.backends.frames.write_animation`)."""
        return write_animation(self.frames, self.times, self.captions, path, timing)
