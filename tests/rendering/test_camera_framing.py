"""The 3D camera keeps what it films in the picture, checked with PyBullet's own matrices."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pybullet as p
import pytest

from ltamp_cli.backends.pybullet.render import (
    Camera,
    FollowCamera,
    frame_points,
    view_matrix,
)

BASE = Camera(target=(0.0, 0.0, 0.75), distance=1.3, yaw=50.0, pitch=-30.0)


def ndc(camera: Camera, points: np.ndarray) -> np.ndarray:
    """Normalised image coordinates ``(n, 2)`` in [-1, 1] of visible points, computed with
    PyBullet's view and projection matrices (not the code under test)."""
    view = np.asarray(view_matrix(camera)).reshape(4, 4).T
    projection = np.asarray(p.computeProjectionMatrixFOV(
        camera.fov, camera.width / camera.height, 0.01, 8.0)).reshape(4, 4).T
    homogeneous = np.c_[points, np.ones(len(points))] @ (projection @ view).T
    assert np.all(homogeneous[:, 3] > 0), "a point is behind the camera"
    return homogeneous[:, :2] / homogeneous[:, 3:4]


@pytest.mark.parametrize("seed", range(6))
def test_framing_shows_every_point_and_uses_the_picture(seed: int) -> None:
    rng = np.random.default_rng(seed)
    centre = rng.uniform([-0.6, -0.6, 0.7], [0.6, 0.6, 1.3])
    points = centre + rng.normal(0.0, rng.uniform(0.05, 0.4), size=(40, 3))
    camera = frame_points(points, BASE, margin=0.85)
    assert (camera.yaw, camera.pitch, camera.width, camera.height) == (50.0, -30.0, 640, 480)
    xy = np.abs(ndc(camera, points))
    assert xy.max() <= 0.85 + 1e-6
    assert xy.max() >= 0.6  # framed tightly, not from far away


def carried_cup_path(n: int = 120) -> list[np.ndarray]:
    """Recorded states: an arm (a fixed box of points at the origin) carrying a cup (a small
    box) out along an arc to 0.9 m and back."""
    arm = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (0.7, 1.5)])
    cup = np.array([[x, y, z] for x in (-0.04, 0.04) for y in (-0.04, 0.04)
                    for z in (0.0, 0.1)])
    frames = []
    for t in np.linspace(0.0, 2 * np.pi, n):
        reach = 0.3 + 0.6 * np.sin(t / 2)
        where = np.array([reach * np.cos(t / 2), reach * np.sin(t / 2), 0.75 + 0.3 * np.sin(t)])
        frames.append(np.vstack([arm, cup + where]))
    return frames


def test_the_following_camera_never_loses_the_carried_cup_and_moves_rarely() -> None:
    follow = FollowCamera(BASE)
    cameras = []
    for points in carried_cup_path():
        camera = follow.update(points)
        assert np.abs(ndc(camera, points)).max() <= 1.0  # nothing cropped, ever
        cameras.append((camera.target, camera.distance))
    still = sum(a == b for a, b in pairwise(cameras))
    assert still >= len(cameras) // 3  # it holds still while the scene fits


def test_the_fixed_camera_of_before_would_lose_the_cup() -> None:
    """The test above is not vacuous: the old fixed camera crops the path."""
    old = Camera(target=(0.0, 0.0, 0.75), distance=1.3, yaw=50.0, pitch=-35.0, width=320,
                 height=240)
    assert any(np.abs(ndc(old, points)).max() > 1.0 for points in carried_cup_path())
