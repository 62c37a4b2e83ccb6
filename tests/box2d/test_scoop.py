"""The Kitchen2D scoop as the reference defines it: a turn, spill scored, bounded motion."""

from __future__ import annotations

import math

import numpy as np
import pytest
from Box2D import b2

from ltamp_cli.backends.box2d.kitchenware import CupSpec
from ltamp_cli.backends.box2d.skills import scoop
from ltamp_cli.backends.box2d.world import Kitchen
from ltamp_cli.motion.timing import peak_rates

CONFIG = scoop.ScoopConfig()
CONTEXT = np.array([7.0, 5.0])
GOOD = np.array([0.59, 0.02, 0.84, -0.48, 0.51, 0.51, 0.15])
SKIM = np.array([0.5, -0.5, 0.95, 0.0, 0.95, 0.5, 0.95])


def test_spoon_is_tilted_in_the_grains_and_upright_at_the_third_waypoint() -> None:
    poses = scoop.spoon_poses(CONTEXT, GOOD, CONFIG)
    assert poses.shape == (5, 3)
    assert np.allclose(poses[:, 2], [0.0, CONFIG.turn, CONFIG.turn, 0.0, 0.0])
    assert CONFIG.turn > 0  # mouth up-left, then turned clockwise upright
    # Entry and exit straight above waypoints 1 and 3, above the rim.
    top = CONFIG.layout.table_top
    assert poses[0, 0] == poses[1, 0] and poses[4, 0] == poses[3, 0]
    assert min(poses[0, 1], poses[4, 1]) > top + CONTEXT[1]


def test_a_trial_turns_the_spoon_holds_it_dynamically_and_scores_spill() -> None:
    seen: dict[str, list[float]] = {"angle": [], "dynamic": []}

    def observe(kitchen: Kitchen) -> None:
        spoon = next(b for b in kitchen.world.bodies if (b.userData or {}).get("name")
                     == "spoon")
        seen["angle"].append(float(spoon.angle))
        seen["dynamic"].append(float(spoon.type == b2.dynamicBody))

    result = scoop.run(CONTEXT, GOOD, 0, CONFIG, observe)
    info = result.info
    assert result.valid and result.score > 0, info
    # The spoon really turned (driven with bounded force, it may lag a little).
    assert max(seen["angle"]) > 0.8 * CONFIG.turn and abs(seen["angle"][-1]) < 0.05
    assert 0 < np.mean(seen["dynamic"]) < 1  # dynamic in the grains, rigid again after
    raw = (info["n_in_spoon"] - info["n_spilled"]) / info["capacity"]
    assert result.score == pytest.approx(float(np.clip(raw, 0, 1)) - 0.5)
    assert info["n_spilled"] <= info["n_elsewhere"]


def test_skimming_the_surface_fails_and_scores_follow_the_formula() -> None:
    result = scoop.run(CONTEXT, SKIM, 0, CONFIG)
    assert result.valid and result.score < 0
    info = result.info
    raw = (info["n_in_spoon"] - info["n_spilled"]) / info["capacity"]
    assert result.score == pytest.approx(float(np.clip(raw, 0, 1)) - 0.5)


def test_reference_setting_has_the_reference_grains() -> None:
    reference = scoop.reference_config()
    assert reference.particle.radius == 0.05
    cup = CupSpec(7.5, 6.0, CONFIG.wall)
    # Same bed, four times as many grains (~1,000 as in the reference for a mid-size cup).
    ratio = scoop.fill_count(cup, reference) / scoop.fill_count(cup, CONFIG)
    assert 3.6 < ratio < 4.4 and 900 < scoop.fill_count(cup, reference) < 1600
    assert scoop.capacity(reference) > 3.5 * scoop.capacity(CONFIG)


def test_commanded_hand_motion_is_acceleration_limited() -> None:
    hands = scoop.hand_path(CONTEXT, GOOD, CONFIG)
    timed = np.concatenate([hands[:1], scoop.timed_hands(hands, CONFIG, 0.01)])
    assert np.allclose(timed[-1], hands[-1])
    speeds, accels = peak_rates(timed, 0.01, ((0, 1), (2,)))
    assert accels[0] <= 5.0 + 1e-6 and accels[1] <= 2.0 + 1e-6
    assert speeds[0] <= CONFIG.air_speed + 1e-6 and speeds[1] <= 1.0 + 1e-6


def test_validity_sees_the_turned_handle() -> None:
    # Upright the same path would be valid; tilted, a high grasp leans the gripper into the
    # left wall of a narrow cup.
    narrow = np.array([5.0, 8.0])
    control = np.array([1.0, -1.0, 0.0, -1.0, 0.0, -1.0, 0.0])
    upright = scoop.ScoopConfig(turn=0.0)
    assert scoop.valid_mask(narrow, control[None], upright)[0]
    assert not scoop.valid_mask(narrow, control[None], CONFIG)[0]
    assert math.isclose(scoop.run(narrow, control, 0, CONFIG).score, -1.0)
