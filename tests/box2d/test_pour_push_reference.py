"""The 2D pour and push as the reference Kitchen2D defines them: carry, tilt sense, settings,
the push's round object, friction joint, rectangular pusher and coast."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ltamp_cli.backends.box2d.skills import pour, push
from ltamp_cli.backends.box2d.world import Kitchen
from ltamp_cli.motion.timing import min_jerk

CONTEXT = np.array([4.0, 4.0, 6.0, 4.0])


def _held_track(control: list[float]) -> tuple[list[tuple[float, float, float]], object]:
    """(x, y, angle) of the held cup after every step of a fast pour, and its result."""
    track: list[tuple[float, float, float]] = []

    def observe(kitchen: Kitchen) -> None:
        held = next(b for b in kitchen.world.bodies if (b.userData or {}).get("name") == "held")
        track.append((float(held.position[0]), float(held.position[1]), float(held.angle)))

    result = pour.run(CONTEXT, np.array(control), 0, pour.PourConfig(), observe)
    return track, result


def test_reference_setting_is_the_reference_implementations() -> None:
    assert (pour.REFERENCE.n_particles, pour.REFERENCE.rotate_speed,
            pour.REFERENCE.max_time) == (500, 0.1, 30.0)
    assert pour.PourConfig().carry_from == (-15.0, 0.0)
    config = push.PushConfig()
    assert (config.object_radius, config.friction_force, config.friction_torque) == (1, 5, 2)
    assert (config.pusher_depth, config.pusher_width, config.speed) == (0.6, 2.0, 10.0)
    assert config.coast_time == 1.0


def test_min_jerk_respects_its_speed_and_acceleration_limits() -> None:
    dt, length, speed, accel = 0.01, 15.0, 10.0, 8.0
    s = np.concatenate([[0.0], min_jerk(length, speed, accel, dt)]) * length
    assert s[-1] == pytest.approx(length) and np.all(np.diff(s) >= 0)
    v = np.diff(s) / dt
    a = np.diff(v) / dt
    assert v.max() <= speed * 1.01 and np.abs(a).max() <= accel * 1.05
    # The slower limit sets the duration: at least one of them is nearly reached.
    assert v.max() > 0.95 * speed or np.abs(a).max() > 0.95 * accel
    assert len(min_jerk(0.0, speed, accel, dt)) == 0


def test_pour_carries_the_full_cup_from_its_start_to_the_pour_pose() -> None:
    control = [0.5, -2.0, 6.0, 2.0]
    track, result = _held_track(control)
    config = pour.PourConfig()
    held = pour.CupSpec(float(CONTEXT[0]), float(CONTEXT[1]), config.wall)
    top = config.layout.table_top
    x0, y0, a0 = track[0]
    assert x0 == pytest.approx(-15.0 - held.handle_x, abs=1e-3)
    assert y0 == pytest.approx(top + config.clearance, abs=1e-3) and a0 == pytest.approx(0.0)
    upright = [(x, y) for x, y, a in track if a == pytest.approx(0.0, abs=1e-9)]
    # It crossed above the target's rim and reached the pour pose before tilting.
    assert max(y for _, y in upright) >= top + CONTEXT[3] + config.carry_margin - 1e-6
    gh = held.grasp_height(control[0])
    assert upright[-1][0] == pytest.approx(control[1] - held.handle_x, abs=1e-3)
    assert upright[-1][1] == pytest.approx(top + CONTEXT[3] + control[2] - gh, abs=1e-3)
    assert result.valid and result.score > 0  # the grains survived the carry


def test_pour_tilts_towards_the_target_from_either_side() -> None:
    left, _ = _held_track([0.5, -2.0, 6.0, 2.0])
    right, _ = _held_track([0.5, 4.0, 4.0, 2.6])
    left_angles = np.array([a for *_, a in left])
    right_angles = np.array([a for *_, a in right])
    assert left_angles.max() <= 1e-6 and left_angles.min() < -1.0  # clockwise from the left
    assert right_angles.min() >= -1e-6 and right_angles.max() > 2.5  # anticlockwise
    assert pour.tilt_sign(-0.5) == -1.0 and pour.tilt_sign(0.0) == -1.0
    assert pour.tilt_sign(np.array([-1.0, 2.0])).tolist() == [-1.0, 1.0]


def test_a_tilt_through_the_target_is_invalid_though_the_start_is_clear() -> None:
    # Grasp just right of the rim, low: the start is clear of everything, but tilting the
    # held cup anticlockwise swings it through the target cup.
    control = np.array([1.0, 3.5, 1.0, math.pi])
    config = pour.PourConfig()
    no_tilt = control.copy()
    no_tilt[3] = 1e-9
    assert pour.valid_mask(CONTEXT, no_tilt[None], config)[0]
    assert not pour.valid_mask(CONTEXT, control[None], config)[0]
    result = pour.run(CONTEXT, control, 0, config)
    assert (result.valid, result.score) == (False, -1.0)


def test_push_object_is_a_disc_and_the_pusher_a_rectangle_along_the_push() -> None:
    config = push.PushConfig()
    context = np.zeros(2)
    # Below the disc, 1.5 from its centre: moving up (thin along y) it is clear; turned
    # to move along x, its 2-wide face reaches over the disc.
    along = np.array([[0.0, -1.5, math.pi / 2, 0.5], [0.0, -1.5, 0.0, 0.5]])
    assert push.valid_mask(context, along, config).tolist() == [True, False]
    # A disc, not a square: the corner direction is clear at a distance a square of
    # half-size 1 would block.
    diagonal = np.array([[-1.2, -1.2, math.pi / 4, 0.5]])
    assert push.valid_mask(context, diagonal, config)[0]


def test_friction_joint_stops_the_object_during_the_coast_and_longer_pushes_go_further() -> None:
    config = push.PushConfig()
    finals = []
    for duration in (0.1, 0.2, 0.3):
        result = push.run(np.array([3.0, 0.0]), np.array([-2.0, 0.0, 0.0, duration]), 0, config)
        assert result.info["final_speed"] < 1e-3  # 5 / mass brakes 10 u/s within the coast
        assert abs(result.info["final_y"]) < 1e-6
        finals.append(result.info["final_x"])
    assert finals[0] > 2.0 and np.all(np.diff(finals) > 0.5)
    # Pushed at the tracked 10 u/s for ~0.1 s more each time: about 1 unit further.
    assert np.diff(finals) == pytest.approx([1.0, 1.0], abs=0.3)


class _PushAway:
    """A stand-in model whose θ* pushes away from every goal (the object stays put)."""

    def most_confident_control(self, context: np.ndarray, rng: np.random.Generator,
                               is_valid: object) -> tuple[np.ndarray, float]:
        return np.array([-2.0, 0.0, math.pi, 0.5]), 0.0


class _CountingBackend:
    """The Box2D backend, counting the controls it runs."""

    def __init__(self) -> None:
        from ltamp_cli.backends.box2d.backend import Kitchen2DBackend

        self.inner = Kitchen2DBackend()
        self.controls: list[np.ndarray] = []

    def __getattr__(self, name: str) -> object:
        return getattr(self.inner, name)

    def run_trial(self, skill: str, context: np.ndarray, control: np.ndarray,
                  seed: int) -> object:
        self.controls.append(np.asarray(control))
        return self.inner.run_trial(skill, context, control, seed)


def test_evaluate_scores_theta_star_and_a_random_valid_control_in_the_same_contexts() -> None:
    from ltamp_cli.cli.evaluate import _live_success_rates

    backend = _CountingBackend()
    star, random_rate = _live_success_rates(backend, "push", _PushAway(), 30, 3)
    rng = np.random.default_rng(3)
    goals = np.array([backend.inner.sample_context("push", rng) for _ in range(30)])
    # Pushing away leaves the object at the origin: success iff the goal is within 2.
    assert star == pytest.approx(np.mean(np.linalg.norm(goals, axis=1) < 2.0))
    assert len(backend.controls) == 60  # θ* and one random control per context
    randoms = np.array(backend.controls[1::2])
    assert backend.inner.is_valid("push", goals[0], randoms).all()
    assert not np.allclose(randoms, randoms[0])
    assert 0.0 <= random_rate <= 1.0
    assert _live_success_rates(_CountingBackend(), "push", _PushAway(), 30, 3) == (
        star, random_rate)
