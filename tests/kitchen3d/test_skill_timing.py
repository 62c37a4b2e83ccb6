"""A learned skill executes at the timing it was trained with: the executor's pour moves the
held cup at the pour trials' speeds (0.2 m/s, 2 rad/s), never pausing at the path's dense
waypoints. At the executor's former joint-speed limited, rest-to-rest timing the cup tilted
at ~0.4 rad/s peak and stopped every ~6 degrees, and a Kitchen3D coffee pour that its trial
poured into the bowl threw 21 of 40 beads past it."""

from __future__ import annotations

import itertools

import numpy as np
import pybullet as p
import pytest

from ltamp_cli.backends.pybullet.executor import skill_timed_configurations
from ltamp_cli.backends.pybullet.robot.arm import PANDA_HOME, PandaArm
from ltamp_cli.backends.pybullet.robot.pose import Pose, rotation_distance
from ltamp_cli.backends.skills3d.pour import POUR_SPEED_M_S, PourSettings
from ltamp_cli.motion.timing import MotionLimits, time_path

DT = 1.0 / 240.0
GRASP = Pose(np.array([0.0, 0.0, 0.1]))  # a tool held 10 cm past the flange


@pytest.fixture(scope="module")
def arm():
    client = p.connect(p.DIRECT)
    try:
        yield PandaArm(client)
    finally:
        p.disconnect(client)


def tool_poses(arm: PandaArm, configurations: np.ndarray) -> list[Pose]:
    poses = []
    for q in configurations:
        arm.set_configuration(q)
        poses.append(arm.end_effector_pose() @ GRASP)
    return poses


def pour_like_path() -> np.ndarray:
    """A tilt of the wrist (joints 6 and 7) with a small shoulder swing: ``(41, 7)``."""
    home = np.asarray(PANDA_HOME, dtype=float)
    s = np.linspace(0.0, 1.0, 41)[:, None]
    delta = np.zeros(7)
    delta[[0, 5, 6]] = [0.2, -1.2, 1.5]
    return home + s * delta


def step_rates(arm: PandaArm, dense: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    poses = tool_poses(arm, dense)
    pairs = list(itertools.pairwise(poses))
    shift = np.array([np.linalg.norm(b.position - a.position) for a, b in pairs])
    turn = np.array([rotation_distance(a, b) for a, b in pairs])
    return shift / DT, turn / DT


def test_the_tool_moves_at_the_skills_speeds_without_pausing(arm: PandaArm) -> None:
    path = pour_like_path()
    angular = PourSettings().angular_speed
    dense = skill_timed_configurations(path, tool_poses(arm, path), POUR_SPEED_M_S, angular, DT)
    assert np.allclose(dense[0], path[0]) and np.allclose(dense[-1], path[-1])
    speed, turn_rate = step_rates(arm, dense)
    # Within a segment the joints move linearly, so the tool's rates wobble a little.
    assert speed.max() <= POUR_SPEED_M_S * 1.15
    assert turn_rate.max() <= angular * 1.15
    # Every step runs at one of the two limits: no pause, no slow start.
    assert np.min(np.maximum(speed / POUR_SPEED_M_S, turn_rate / angular)) >= 0.85
    # The former executor timing (1.2 rad/s joints, 2 rad/s^2, rest at every waypoint) is
    # far slower on the same path: its mean turn rate is a fraction of the skill's.
    old = time_path(path, MotionLimits((1.2,), (2.0,)), DT)
    _, old_turn = step_rates(arm, old)
    assert old_turn.mean() < 0.5 * turn_rate.mean()


def test_bad_timing_inputs_are_refused(arm: PandaArm) -> None:
    path = pour_like_path()
    with pytest.raises(ValueError, match="tool poses"):
        skill_timed_configurations(path, tool_poses(arm, path[:-1]), 0.2, 2.0, DT)
    with pytest.raises(ValueError, match="positive"):
        skill_timed_configurations(path, tool_poses(arm, path), 0.2, 0.0, DT)
