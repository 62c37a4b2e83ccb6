"""SAPIEN Kitchen3D trials: the protocol, and agreement with PyBullet on clear-cut controls.

The two engines differ on borderline controls; the controls here are the PyBullet tests'
clearly good and clearly bad ones, on the nominal kitchenware.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("sapien")

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.kitchenware_geometry import SpoonDims
from ltamp_cli.backends.protocol import SkillBackend
from ltamp_cli.backends.pybullet.skills.pour import (
    NOMINAL_BOWL,
    NOMINAL_CUP,
    POUR_TAU,
    PourContext,
)
from ltamp_cli.backends.pybullet.skills.scoop import ScoopContext
from ltamp_cli.backends.sapien.world import SapienWorld

POUR_CONTEXT = PourContext(NOMINAL_BOWL, NOMINAL_CUP).to_array()
# Pivot on the cup's lip over the inside of the bowl, tilted to 135°.
GOOD_POUR = np.array([-3 * math.pi / 4, -0.5, 0.5, 0.15, 0.12])
# Same lip pivot beyond the bowl's rim, only tilted to 90°: most beads miss the bowl.
BAD_POUR = np.array([-math.pi / 2, -0.5, 0.5, 0.75, 0.12])
# The cup starts inside the bowl's wall.
COLLIDING_POUR = np.array([-3 * math.pi / 4, -0.5, 0.5, 0.5, 0.0])
SCOOP_CONTEXT = ScoopContext(NOMINAL_BOWL, SpoonDims(0.2)).to_array()
# A short drag low through the heap, then straight up.
GOOD_SCOOP = np.array([0.25, -0.05, 0.0, -0.015, 0.02])
# No drag at all, above the heap.
BAD_SCOOP = np.array([0.0, 0.0, 0.0, 0.02, 0.03])


@pytest.fixture(scope="module")
def sapien_backend() -> SkillBackend:
    backend = load_backend("sapien")
    yield backend
    backend.close()


@pytest.fixture(scope="module")
def pybullet_backend() -> SkillBackend:
    backend = load_backend("pybullet")
    yield backend
    backend.close()


def test_sapien_backend_implements_the_protocol_like_pybullet(
    sapien_backend: SkillBackend, pybullet_backend: SkillBackend
) -> None:
    assert isinstance(sapien_backend, SkillBackend)
    assert sapien_backend.name == "sapien"
    assert dict(sapien_backend.skills()) == dict(pybullet_backend.skills())
    for skill in ("pour", "scoop", "push", "stir"):
        a = sapien_backend.sample_context(skill, np.random.default_rng(3))
        b = pybullet_backend.sample_context(skill, np.random.default_rng(3))
        assert np.array_equal(a, b)
    rng = np.random.default_rng(4)
    controls = sapien_backend.skills()["pour"].control.sample_uniform(rng, 30)
    valid = sapien_backend.is_valid("pour", POUR_CONTEXT, controls)
    assert valid.shape == (30,) and 0 < valid.sum() < 30
    assert np.array_equal(valid, pybullet_backend.is_valid("pour", POUR_CONTEXT, controls))
    with pytest.raises(KeyError, match="fly"):
        sapien_backend.sample_context("fly", rng)
    with pytest.raises(ValueError, match="control of 5"):
        sapien_backend.run_trial("pour", POUR_CONTEXT, GOOD_POUR[:3], seed=0)


def test_good_pour_succeeds_in_both_engines(
    sapien_backend: SkillBackend, pybullet_backend: SkillBackend
) -> None:
    ours = sapien_backend.run_trial("pour", POUR_CONTEXT, GOOD_POUR, seed=0)
    theirs = pybullet_backend.run_trial("pour", POUR_CONTEXT, GOOD_POUR, seed=0)
    assert ours.valid and theirs.valid
    assert ours.score > 0 and theirs.score > 0, (ours.info, theirs.info)
    info = ours.info
    assert info["fraction_in_bowl"] > POUR_TAU
    assert info["beads_lost"] == 0
    # Same seed, same latents: the same number of beads was spawned in both engines.
    assert info["beads_total"] == theirs.info["beads_total"]
    assert info["beads_in_cup_start"] >= info["beads_total"] - 5
    assert info["beads_in_bowl_end"] + info["beads_in_cup_end"] <= info["beads_in_cup_start"]


def test_bad_pour_fails_in_both_engines(
    sapien_backend: SkillBackend, pybullet_backend: SkillBackend
) -> None:
    ours = sapien_backend.run_trial("pour", POUR_CONTEXT, BAD_POUR, seed=0)
    theirs = pybullet_backend.run_trial("pour", POUR_CONTEXT, BAD_POUR, seed=0)
    assert ours.valid and theirs.valid
    assert ours.score < 0 and theirs.score < 0, (ours.info, theirs.info)
    assert ours.info["fraction_in_bowl"] < 0.6
    assert ours.info["beads_lost"] == 0


def test_invalid_pour_is_rejected_without_simulating(
    sapien_backend: SkillBackend, monkeypatch: pytest.MonkeyPatch
) -> None:
    def no_physics(*_: object, **__: object) -> None:
        raise AssertionError("an invalid control was simulated")

    monkeypatch.setattr(SapienWorld, "step", no_physics)
    monkeypatch.setattr(SapienWorld, "reset", no_physics)
    result = sapien_backend.run_trial("pour", POUR_CONTEXT, COLLIDING_POUR, seed=0)
    assert not result.valid and result.score == -1.0
    assert "bowl" in result.info["reason"]


def test_trials_are_deterministic_whatever_ran_before(sapien_backend: SkillBackend) -> None:
    first = sapien_backend.run_trial("pour", POUR_CONTEXT, BAD_POUR, seed=7)
    sapien_backend.run_trial("pour", POUR_CONTEXT, GOOD_POUR, seed=8)
    second = sapien_backend.run_trial("pour", POUR_CONTEXT, BAD_POUR, seed=7)
    fresh = load_backend("sapien")
    third = fresh.run_trial("pour", POUR_CONTEXT, BAD_POUR, seed=7)
    fresh.close()
    assert first == second == third
    other_seed = sapien_backend.run_trial("pour", POUR_CONTEXT, BAD_POUR, seed=9)
    assert other_seed.info != first.info


def test_scoop_good_and_bad_on_sapien(sapien_backend: SkillBackend) -> None:
    good = sapien_backend.run_trial("scoop", SCOOP_CONTEXT, GOOD_SCOOP, seed=1)
    bad = sapien_backend.run_trial("scoop", SCOOP_CONTEXT, BAD_SCOOP, seed=1)
    assert good.valid and bad.valid
    assert good.score > 0, good.info
    assert bad.score == -1.0 and bad.info["beads_in_spoon_end"] == 0
    assert good.info["beads_lost"] == bad.info["beads_lost"] == 0
    assert good.info["beads_in_bowl_start"] == good.info["beads_total"]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_scoop_labels_agree_with_pybullet(
    sapien_backend: SkillBackend, pybullet_backend: SkillBackend, seed: int
) -> None:
    for control, succeeds in ((GOOD_SCOOP, True), (BAD_SCOOP, False)):
        ours = sapien_backend.run_trial("scoop", SCOOP_CONTEXT, control, seed=seed)
        theirs = pybullet_backend.run_trial("scoop", SCOOP_CONTEXT, control, seed=seed)
        assert (ours.score > 0) == (theirs.score > 0) == succeeds, (ours.info, theirs.info)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_pour_labels_agree_with_pybullet_over_seeds(
    sapien_backend: SkillBackend, pybullet_backend: SkillBackend, seed: int
) -> None:
    for control, succeeds in ((GOOD_POUR, True), (BAD_POUR, False)):
        ours = sapien_backend.run_trial("pour", POUR_CONTEXT, control, seed=seed)
        theirs = pybullet_backend.run_trial("pour", POUR_CONTEXT, control, seed=seed)
        assert (ours.score > 0) == (theirs.score > 0) == succeeds, (ours.info, theirs.info)
