"""A pick ignores a revolved object's spin about its own axis (the cup of push_to_reach seed 0
turned ~0.3 rad on the table, which made the executor re-solve, and fail, its approach)."""

from __future__ import annotations

import numpy as np

from ltamp_cli.backends.pybullet.executor import without_spin
from ltamp_cli.backends.pybullet.robot.pose import Pose, rotation_distance


def test_spin_about_the_axis_is_dropped_and_tilt_and_position_kept() -> None:
    expected = Pose.from_euler(np.array([-0.45, -0.3, 0.70]), yaw=0.2)
    spun = Pose.from_euler(np.array([-0.452, -0.297, 0.70]), yaw=0.2 + 0.34)
    aligned = without_spin(spun, expected)
    assert rotation_distance(aligned, expected) < 1e-9
    assert np.allclose(aligned.position, spun.position)
    # A tilt of the axis is not a spin: it stays (an object knocked over still counts).
    tilted = Pose.from_euler(np.array([-0.45, -0.3, 0.70]), roll=0.3, yaw=0.2 + 0.34)
    kept = without_spin(tilted, expected)
    assert abs(rotation_distance(kept, expected) - 0.3) < 1e-6
    assert np.allclose(kept.rotation()[:, 2], tilted.rotation()[:, 2])
