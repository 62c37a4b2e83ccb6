"""Small CPU images of a PyBullet world with the TinyRenderer (works headless)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as p


@dataclass(frozen=True)
class Camera:
    """A look-at camera: ``target`` (m), ``distance`` (m), ``yaw``/``pitch`` (degrees),
    image ``width`` × ``height`` pixels and vertical field of view ``fov`` (degrees)."""

    target: tuple[float, float, float] = (0.0, 0.0, 0.08)
    distance: float = 0.6
    yaw: float = 30.0
    pitch: float = -30.0
    width: int = 320
    height: int = 240
    fov: float = 50.0


def render_rgb(client: int, camera: Camera | None = None) -> np.ndarray:
    """One RGB frame ``(height, width, 3)`` uint8 of the world in ``client``."""
    camera = camera or Camera()
    view = p.computeViewMatrixFromYawPitchRoll(
        list(camera.target),
        camera.distance,
        camera.yaw,
        camera.pitch,
        0.0,
        2,
        physicsClientId=client,
    )
    projection = p.computeProjectionMatrixFOV(
        camera.fov, camera.width / camera.height, 0.01, 5.0, physicsClientId=client
    )
    _, _, rgba, _, _ = p.getCameraImage(
        camera.width,
        camera.height,
        view,
        projection,
        renderer=p.ER_TINY_RENDERER,
        physicsClientId=client,
    )
    image = np.asarray(rgba, dtype=np.uint8).reshape(camera.height, camera.width, 4)
    return image[..., :3].copy()


class FrameRecorder:
    """A step callback that keeps one frame every ``every`` simulation steps."""

    def __init__(self, client: int, every: int = 8, camera: Camera | None = None) -> None:
        if every < 1:
            raise ValueError("every must be at least 1")
        self.client = client
        self.every = every
        self.camera = camera or Camera()
        self.frames: list[np.ndarray] = []

    def __call__(self, step: int) -> None:
        if step % self.every == 0:
            self.frames.append(render_rgb(self.client, self.camera))
