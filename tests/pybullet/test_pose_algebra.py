"""Pose composition, inverse, Euler angles and rotation matrices in plain quaternion algebra
agree with scipy's Rotation (the reference they replaced for speed)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ltamp_cli.backends.pybullet.robot.pose import Pose, tilt_roll_pitch


def test_pose_algebra_matches_scipy_rotations() -> None:
    rng = np.random.default_rng(3)
    for _ in range(300):
        a = Pose(rng.normal(size=3), rng.normal(size=4))
        b = Pose(rng.normal(size=3), rng.normal(size=4))
        ra, rb = Rotation.from_quat(a.quaternion), Rotation.from_quat(b.quaternion)
        c = a @ b
        np.testing.assert_allclose(c.position, a.position + ra.apply(b.position), atol=1e-12)
        np.testing.assert_allclose(c.quaternion, (ra * rb).as_quat(), atol=1e-12)
        inverse = a.inverse()
        np.testing.assert_allclose(inverse.position, -ra.inv().apply(a.position), atol=1e-12)
        np.testing.assert_allclose((a @ inverse).position, np.zeros(3), atol=1e-12)
        np.testing.assert_allclose(a.rotation(), ra.as_matrix(), atol=1e-12)
        np.testing.assert_allclose(a.euler(), ra.as_euler("xyz"), atol=1e-9)


def test_tilt_of_an_upright_and_a_tipped_frame() -> None:
    upright = Pose.from_euler(np.zeros(3), yaw=2.0)
    assert np.allclose(tilt_roll_pitch(upright), (0.0, 0.0), atol=1e-12)
    roll, pitch = tilt_roll_pitch(Pose.from_euler(np.zeros(3), roll=0.3, pitch=-0.2, yaw=1.0))
    assert np.isclose(roll, 0.3) and np.isclose(pitch, -0.2)
