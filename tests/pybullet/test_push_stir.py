"""Push and stir trials on the PyBullet Kitchen3D backend: scores, validity, conservation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.kitchenware_geometry import ContainmentPrism
from ltamp_cli.backends.protocol import SkillBackend
from ltamp_cli.backends.pybullet.skills.pour import NOMINAL_CUP
from ltamp_cli.backends.pybullet.skills.push import (
    PUSH_ROTATION_TOLERANCE_RAD,
    PUSH_TOLERANCE_M,
    PushContext,
    push_path,
    push_score,
    rotation_angle,
)
from ltamp_cli.backends.pybullet.skills.stir import (
    STIR_MIN_TIME_S,
    TipTracker,
    cup_of,
    stir_path,
)

# A 5 cm, 0.3 kg cube (friction 0.5), the goal 15 cm ahead.
PUSH_CONTEXT = np.array([0.05, 0.3, 0.5, 0.15])
# Centred, at mid height, slowly, the pad travelling 15 cm past the block's back face.
PUSH_GOOD = np.array([0.5, 0.1, 0.0, 0.15])
# The same push travelling 5 cm less.
PUSH_SHORT = np.array([0.5, 0.1, 0.0, 0.10])
# Pad centre 1.5 cm above a 5 cm block's base: the 3 cm pad would touch the table.
PUSH_LOW = np.array([0.3, 0.1, 0.0, 0.15])

STIR_CONTEXT = np.array([NOMINAL_CUP.top_diameter, NOMINAL_CUP.height, NOMINAL_CUP.base_diameter])
# Two turns of radius 1.8 cm, tip 2 cm above the cup's base (inside the beads).
STIR_GOOD = np.array([0.018, 0.02, 2.0, 0.1])
# The same circles with the tip 1 cm above the rim: nothing is stirred.
STIR_ABOVE = np.array([0.018, 0.11, 2.0, 0.1])
# Circles wider than the cup: the rod would cut through the wall.
STIR_WIDE = np.array([0.045, 0.02, 2.0, 0.1])


@pytest.fixture(scope="module")
def backend() -> SkillBackend:
    backend = load_backend("pybullet")
    yield backend
    backend.close()


def test_push_and_stir_are_registered_with_their_spaces(backend: SkillBackend) -> None:
    skills = backend.skills()
    assert skills["push"].context.dim == 4 and skills["push"].control.dim == 4
    assert skills["stir"].context.dim == 3 and skills["stir"].control.dim == 4
    rng = np.random.default_rng(0)
    context = backend.sample_context("push", rng)
    spec = skills["push"]
    assert np.all(context >= spec.context.low_array()) and np.all(
        context <= spec.context.high_array())


def test_push_score_crosses_zero_at_both_tolerances_and_toppling_fails() -> None:
    # The reference's criterion: position error <= 2.5 cm and rotation error <= 0.1 rad.
    assert PUSH_TOLERANCE_M == 0.025 and PUSH_ROTATION_TOLERANCE_RAD == 0.1
    assert push_score(0.0, 0.0) == 1.0
    assert push_score(PUSH_TOLERANCE_M, 0.0) == pytest.approx(0.0)
    assert push_score(2 * PUSH_TOLERANCE_M, 0.0) == pytest.approx(-1.0)
    assert push_score(10.0, 0.0) == -1.0
    assert push_score(0.0, PUSH_ROTATION_TOLERANCE_RAD) == pytest.approx(0.0)
    # On target but turned by 0.15 rad: a failure; the worse of the two errors decides.
    assert push_score(0.0, 0.15) < 0
    assert push_score(0.005, 0.05) == pytest.approx(0.5)
    assert push_score(0.0, math.radians(60)) == -1.0


def test_rotation_angle_of_a_turned_and_a_tipped_block() -> None:
    half = 0.3 / 2
    yawed = np.array([0.0, 0.0, math.sin(half), math.cos(half)])
    assert rotation_angle(yawed) == pytest.approx(0.3)
    assert rotation_angle(-yawed) == pytest.approx(0.3)  # q and -q are one rotation
    tipped = np.array([math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4)])
    assert rotation_angle(tipped) == pytest.approx(math.pi / 2)
    assert rotation_angle(np.array([0.0, 0.0, 0.0, 1.0])) == 0.0


def test_push_path_is_a_straight_line_along_x_ending_at_the_contact_point() -> None:
    scene = PushContext.from_array(PUSH_CONTEXT)
    path = push_path(scene, PUSH_GOOD)
    assert np.allclose(path.positions[:, 1:], path.positions[0, 1:])
    # The pad's front face ends ``travel`` past the block's resting back face.
    front = path.positions[-1, 0] + 0.008
    assert front == pytest.approx(PUSH_GOOD[3] - scene.size / 2)
    # ... wherever the goal is: the path never sees it (a pure goal, issue #20)
    other = PushContext.from_array(np.array([0.05, 0.3, 0.5, 0.07]))
    np.testing.assert_array_equal(push_path(other, PUSH_GOOD).positions, path.positions)


def test_push_validity_rejects_a_pad_that_would_touch_the_table(backend: SkillBackend) -> None:
    valid = backend.is_valid("push", PUSH_CONTEXT, np.stack([PUSH_GOOD, PUSH_LOW]))
    assert valid.tolist() == [True, False]
    result = backend.run_trial("push", PUSH_CONTEXT, PUSH_LOW, seed=0)
    assert not result.valid and result.score == -1.0


def test_good_push_reaches_the_target_and_a_short_one_fails(backend: SkillBackend) -> None:
    good = backend.run_trial("push", PUSH_CONTEXT, PUSH_GOOD, seed=0)
    short = backend.run_trial("push", PUSH_CONTEXT, PUSH_SHORT, seed=0)
    assert good.valid and good.info["error_m"] < 0.01 and good.score > 0.4
    assert good.info["rotation_rad"] < 0.05 and not good.info["toppled"]
    # Stopping 5 cm short leaves the block about 5 cm short.
    assert short.score < -0.5 and 0.04 < short.info["error_m"] < 0.06
    assert short.info["final_xy"][0] < good.info["final_xy"][0] - 0.04


def test_push_outcome_scores_every_goal_exactly(backend: SkillBackend) -> None:
    """The goal is a pure goal: the same push with another goal ends the same way, and the
    declared outcome's score reproduces each trial's score (what hindsight relabelling
    relies on); the achieved goal is where the block ended."""
    spec = backend.skills()["push"]
    assert spec.outcome is not None and spec.outcome.goals == (3,)
    assert spec.context.names[3] == "goal_x" and spec.control.names[3] == "travel"
    far = PUSH_CONTEXT.copy()
    far[3] = 0.22
    here = backend.run_trial("push", PUSH_CONTEXT, PUSH_GOOD, seed=1)
    there = backend.run_trial("push", far, PUSH_GOOD, seed=1)
    assert here.outcome is not None and here.outcome == there.outcome
    assert here.score > 0 > there.score  # 15 cm reached, 22 cm missed by ~7 cm
    both = spec.outcome.scores(np.stack([PUSH_CONTEXT, far]), np.stack([PUSH_GOOD] * 2),
                               np.array([here.outcome] * 2))
    np.testing.assert_allclose(both, [here.score, there.score], atol=1e-9)
    assert spec.outcome.achieved_goal is not None
    achieved = spec.outcome.achieved_goal(np.array([here.outcome]))
    assert achieved[0, 0] == pytest.approx(here.info["final_xy"][0])


def test_push_is_deterministic_given_the_seed(backend: SkillBackend) -> None:
    a = backend.run_trial("push", PUSH_CONTEXT, PUSH_GOOD, seed=3)
    b = backend.run_trial("push", PUSH_CONTEXT, PUSH_GOOD, seed=3)
    assert a.info["final_xy"] == b.info["final_xy"]


def test_stir_path_circles_about_the_cup_axis_at_the_tip_height() -> None:
    path = stir_path(cup_of(STIR_CONTEXT), STIR_GOOD)
    circle = path.positions[2:-2]
    assert np.allclose(np.hypot(circle[:, 0], circle[:, 1]), STIR_GOOD[0])
    assert np.allclose(circle[:, 2], STIR_GOOD[1])
    assert path.positions[0, 2] > NOMINAL_CUP.height and path.positions[-1, 2] > NOMINAL_CUP.height


def test_tip_tracker_needs_time_and_travel_inside() -> None:
    prism = ContainmentPrism((-0.03, -0.03, 0.003), (0.03, 0.03, 0.1))
    dt = 1.0 / 240.0
    still = TipTracker(prism, dt)
    for _ in range(int(STIR_MIN_TIME_S / dt) + 10):
        still.add(np.array([0.0, 0.0, 0.02]))  # inside, but not moving
    assert not still.stirred
    outside = TipTracker(prism, dt)
    for angle in np.linspace(0, 4 * math.pi, 400):
        outside.add(np.array([0.05 * math.cos(angle), 0.05 * math.sin(angle), 0.02]))
    assert not outside.stirred and outside.time_inside_s == 0.0
    moving = TipTracker(prism, dt)
    for angle in np.linspace(0, 4 * math.pi, 400):
        moving.add(np.array([0.02 * math.cos(angle), 0.02 * math.sin(angle), 0.02]))
    assert moving.stirred


def test_stir_validity_rejects_circles_through_the_wall(backend: SkillBackend) -> None:
    valid = backend.is_valid("stir", STIR_CONTEXT, np.stack([STIR_GOOD, STIR_ABOVE, STIR_WIDE]))
    assert valid.tolist() == [True, True, False]


@pytest.mark.slow
def test_stir_keeps_every_bead_in_the_cup_and_displaces_them(backend: SkillBackend) -> None:
    good = backend.run_trial("stir", STIR_CONTEXT, STIR_GOOD, seed=0)
    above = backend.run_trial("stir", STIR_CONTEXT, STIR_ABOVE, seed=0)
    # Conservation: every bead that started in the cup is still in it, none lost.
    for result in (good, above):
        assert result.info["beads_in_cup_start"] == result.info["beads_total"]
        assert result.info["beads_in_cup_end"] == result.info["beads_total"]
        assert result.info["fraction_kept"] == 1.0 and result.info["beads_lost"] == 0
    assert good.info["stirred"] and good.score > 0
    # Stirring moved the beads several times further than settling alone did.
    assert good.info["mean_displacement_m"] > 3 * above.info["mean_displacement_m"]
    assert not above.info["stirred"] and above.score == -1.0
