"""Pour trials on the PyBullet Kitchen3D backend: score, validity, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.protocol import SkillBackend
from ltamp_cli.backends.pybullet.skills.pour import (
    NOMINAL_BOWL,
    NOMINAL_CUP,
    POUR_CONTEXT,
    POUR_TAU,
    PourContext,
    pour_path,
)
from ltamp_cli.backends.pybullet.skills.scoring import piecewise_linear_score
from ltamp_cli.backends.pybullet.world import PhysicsWorld

CONTEXT = PourContext(NOMINAL_BOWL, NOMINAL_CUP).to_array()
# Pivot on the cup's lip over the inside of the bowl, tilted to 135°.
GOOD = np.array([-3 * math.pi / 4, -0.5, 0.5, 0.15, 0.12])
# Same lip pivot but beyond the bowl's rim, only tilted to 90°: most beads miss the bowl.
BAD = np.array([-math.pi / 2, -0.5, 0.5, 0.75, 0.12])
# Cup starts inside the bowl's wall.
COLLIDING = np.array([-3 * math.pi / 4, -0.5, 0.5, 0.5, 0.0])


@pytest.fixture(scope="module")
def backend() -> SkillBackend:
    backend = load_backend("pybullet")
    yield backend
    backend.close()


def test_score_is_the_piecewise_linear_function() -> None:
    assert piecewise_linear_score(0.0, 0.9) == -1.0
    assert piecewise_linear_score(0.9, 0.9) == pytest.approx(0.0)
    assert piecewise_linear_score(1.0, 0.9) == pytest.approx(1.0)
    assert piecewise_linear_score(0.45, 0.9) == pytest.approx(-0.5)
    assert piecewise_linear_score(0.95, 0.9) == pytest.approx(0.5)


@given(st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.floats(0.05, 0.95))
def test_score_is_monotone_and_positive_exactly_above_tau(a: float, b: float, tau: float) -> None:
    low, high = sorted((a, b))
    assert piecewise_linear_score(low, tau) <= piecewise_linear_score(high, tau) + 1e-12
    assert (piecewise_linear_score(high, tau) > 0) == (high > tau)


def test_pour_path_rotates_about_the_pivot_in_sixteenths_of_pi() -> None:
    scene = PourContext.from_array(CONTEXT)
    path = pour_path(scene, GOOD)
    assert len(path) == 13  # 0 .. 3π/4 in π/16 steps
    # The cup-frame pivot stays at the same world point along the whole path.
    pivot_world = np.array([0.15 * NOMINAL_BOWL.top_diameter, 0.0, NOMINAL_BOWL.height + 0.12])
    pivot_cup = np.array([-0.5 * NOMINAL_CUP.top_diameter, 0.0, NOMINAL_CUP.height])
    moved = path.transform(pivot_cup[None])[:, 0]
    assert np.allclose(moved, pivot_world, atol=1e-9)
    assert np.allclose(path.rotations()[-1].as_rotvec(), [0.0, -3 * math.pi / 4, 0.0])


def test_known_good_pour_succeeds_and_conserves_beads(backend: SkillBackend) -> None:
    result = backend.run_trial("pour", CONTEXT, GOOD, seed=0)
    assert result.valid
    assert result.score > 0, result.info
    info = result.info
    assert info["beads_in_cup_start"] >= 10
    assert info["beads_lost"] == 0
    assert info["beads_in_bowl_end"] + info["beads_in_cup_end"] <= info["beads_in_cup_start"]
    assert info["fraction_in_bowl"] > POUR_TAU


def test_known_bad_pour_fails(backend: SkillBackend) -> None:
    assert backend.is_valid("pour", CONTEXT, BAD).tolist() == [True]
    result = backend.run_trial("pour", CONTEXT, BAD, seed=0)
    assert result.valid and result.score < 0, result.info
    assert result.info["beads_lost"] == 0


def test_invalid_pour_is_rejected_without_simulating(
    backend: SkillBackend, monkeypatch: pytest.MonkeyPatch
) -> None:
    def no_physics(*_: object, **__: object) -> None:
        raise AssertionError("an invalid control was simulated")

    monkeypatch.setattr(PhysicsWorld, "step", no_physics)
    monkeypatch.setattr(PhysicsWorld, "reset", no_physics)
    assert backend.is_valid("pour", CONTEXT, np.stack([COLLIDING, GOOD])).tolist() == [False, True]
    result = backend.run_trial("pour", CONTEXT, COLLIDING, seed=0)
    assert not result.valid and result.score == -1.0
    assert "bowl" in result.info["reason"]


def test_validity_matches_the_reason_for_random_controls(backend: SkillBackend) -> None:
    rng = np.random.default_rng(5)
    spec = backend.skills()["pour"]
    context = backend.sample_context("pour", rng)
    controls = spec.control.sample_uniform(rng, 40)
    valid = backend.is_valid("pour", context, controls)
    assert valid.shape == (40,)
    # The box is wide (pivots below the rim, beside the bowl): both outcomes must occur.
    assert 0 < valid.sum() < 40


def test_sampled_contexts_lie_in_the_context_box(backend: SkillBackend) -> None:
    rng = np.random.default_rng(0)
    contexts = np.stack([backend.sample_context("pour", rng) for _ in range(200)])
    assert np.all(contexts >= POUR_CONTEXT.low_array() - 1e-12)
    assert np.all(contexts <= POUR_CONTEXT.high_array() + 1e-12)
    assert np.all(contexts[:, 2] < contexts[:, 0])  # bowl base narrower than its rim
    assert contexts.std(axis=0).min() > 0.003


def test_pour_trial_is_deterministic_given_the_seed(backend: SkillBackend) -> None:
    first = backend.run_trial("pour", CONTEXT, BAD, seed=7)
    second = backend.run_trial("pour", CONTEXT, BAD, seed=7)
    assert first == second
