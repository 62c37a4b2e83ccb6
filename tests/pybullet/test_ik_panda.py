"""IK with restarts agrees with forward kinematics on the real Panda model."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pybullet
import pytest

from ltamp_cli.backends.pybullet.robot import IKConfig, PandaArm, Pose, solve_ik
from ltamp_cli.backends.pybullet.robot.ik import pose_error, wrap_into_limits


@pytest.fixture(scope="module")
def arm() -> Iterator[PandaArm]:
    client = pybullet.connect(pybullet.DIRECT)
    try:
        yield PandaArm(client)
    finally:
        pybullet.disconnect(physicsClientId=client)


def test_fk_of_home_matches_the_urdf_grasp_target(arm: PandaArm) -> None:
    pose = arm.forward_kinematics(np.zeros(7))
    # Straight-up arm: the grasp target is above the base, pointing down.
    assert pose.position[2] > 0.8
    assert np.allclose(pose.rotation()[:, 2], [0.0, 0.0, -1.0], atol=1e-6)


def test_ik_reaches_random_reachable_targets_verified_by_fk(arm: PandaArm) -> None:
    rng = np.random.default_rng(7)
    config = IKConfig()
    n_targets, solved = 40, 0
    for _ in range(n_targets):
        target = arm.forward_kinematics(arm.sample_configuration(rng))
        arm.set_configuration(np.zeros(7))
        before = arm.get_configuration()
        q = solve_ik(arm, target, rng, config)
        assert np.allclose(arm.get_configuration(), before)  # the arm is restored
        if q is None:
            continue
        solved += 1
        assert arm.within_limits(q)
        position_error, orientation_error = pose_error(arm, q, target)
        assert position_error <= config.position_tolerance
        assert orientation_error <= config.orientation_tolerance
    # Uniform joint samples include awkward poses near the limits; ~96% are solved.
    assert solved >= 0.85 * n_targets


def test_ik_returns_none_for_an_unreachable_target(arm: PandaArm) -> None:
    far = Pose(np.array([2.0, 0.0, 0.5]))
    assert solve_ik(arm, far, np.random.default_rng(0), IKConfig(restarts=3)) is None


def test_ik_respects_a_validity_filter(arm: PandaArm) -> None:
    rng = np.random.default_rng(1)
    target = arm.forward_kinematics(np.array([0.3, 0.2, -0.1, -2.0, 0.1, 2.0, 0.5]))
    q = solve_ik(arm, target, rng, is_valid=lambda q: q[0] < 0.0)
    # Any redundant solution with joint 1 negative will do; the first seed gives q[0] > 0.
    if q is not None:
        assert q[0] < 0.0
        assert pose_error(arm, q, target)[0] <= IKConfig().position_tolerance
    assert solve_ik(arm, target, rng, IKConfig(restarts=2), is_valid=lambda q: False) is None


def test_wrap_into_limits(arm: PandaArm) -> None:
    q = np.array([2 * np.pi + 0.1, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0])
    wrapped = wrap_into_limits(arm, q)
    assert wrapped is not None and wrapped[0] == pytest.approx(0.1)
    assert wrap_into_limits(arm, np.array([0.0, 2.5, 0.0, -1.0, 0.0, 1.0, 0.0])) is None
