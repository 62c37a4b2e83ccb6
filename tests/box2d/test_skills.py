"""Kitchen2D skills on real Box2D physics: scores, validity, determinism, conservation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.box2d.backend import Kitchen2DBackend, render_trial
from ltamp_cli.backends.protocol import SkillBackend

# (skill, context, known-good control, known-bad but valid control)
CASES = {
    "pour": ([4.0, 4.0, 6.0, 4.0], [0.5, -2.0, 6.0, 2.0], [0.5, -6.0, 6.0, 2.0]),
    "scoop": (
        [7.0, 5.0],
        # Tilted mouth-left into the bed, sweep left, turn upright low in the bed, lift.
        [0.59, 0.02, 0.84, -0.48, 0.51, 0.51, 0.15],
        [0.5, -0.5, 0.95, 0.0, 0.95, 0.5, 0.95],  # skims the bed's surface
    ),
    "push": ([3.0, 0.0], [-2.0, 0.0, 0.0, 0.1], [-2.0, 0.0, math.pi, 0.5]),
}


@pytest.fixture(scope="module")
def backend() -> Kitchen2DBackend:
    made = load_backend("box2d")
    assert isinstance(made, Kitchen2DBackend)
    return made


def test_backend_implements_protocol(backend: Kitchen2DBackend) -> None:
    assert isinstance(backend, SkillBackend)
    dims = {name: (s.context.dim, s.control.dim) for name, s in backend.skills().items()}
    assert dims == {"pour": (4, 4), "scoop": (2, 7), "push": (2, 4)}


@pytest.mark.parametrize("skill", sorted(CASES))
def test_known_good_scores_positive_and_known_bad_negative(
    backend: Kitchen2DBackend, skill: str
) -> None:
    context, good, bad = (np.array(v) for v in CASES[skill])
    assert backend.is_valid(skill, context, np.stack([good, bad])).all()
    for seed in (0, 1):
        result = backend.run_trial(skill, context, good, seed)
        assert result.valid and result.score > 0, result.info
    result = backend.run_trial(skill, context, bad, 0)
    assert result.valid and result.score < 0, result.info


@pytest.mark.parametrize("skill", ["pour", "scoop"])
def test_particles_are_conserved(backend: Kitchen2DBackend, skill: str) -> None:
    context, good, bad = (np.array(v) for v in CASES[skill])
    for control in (good, bad):
        info = backend.run_trial(skill, context, control, 3).info
        n = info["n_particles"]
        assert n >= 100
        assert info["n_in_world"] == n  # none escaped the world or became NaN
        counted = sum(v for k, v in info.items() if k.startswith("n_in_") and k != "n_in_world")
        assert counted + info["n_elsewhere"] == n


def test_pour_fraction_matches_score(backend: Kitchen2DBackend) -> None:
    context, good, _ = (np.array(v) for v in CASES["pour"])
    result = backend.run_trial("pour", context, good, 0)
    x = result.info["fraction"]
    assert result.score == pytest.approx(math.exp(2 * (10 * x - 9.5)) - 1)
    assert result.info["n_in_target"] == round(x * result.info["n_particles"])


def test_colliding_start_scores_minus_one_without_simulating(backend: Kitchen2DBackend) -> None:
    # Grasp point just above the target's rim, held cup straight through the target cup.
    pour_bad = np.array([0.5, 0.0, 1.0, 2.0])
    scoop_bad = np.array([0.0, -1.0, 0.0, 0.0, 0.0, 1.0, 0.0])  # gripper into the cup wall
    push_bad = np.array([0.2, 0.1, 0.0, 1.0])  # pusher inside the object
    for skill, context, control in (
        ("pour", [4.0, 5.0, 6.0, 3.0], pour_bad),
        ("scoop", [5.0, 8.0], scoop_bad),
        ("push", [3.0, 0.0], push_bad),
    ):
        assert not backend.is_valid(skill, np.array(context), control[None])[0]
        result = backend.run_trial(skill, np.array(context), control, 0)
        assert (result.valid, result.score) == (False, -1.0)
        assert "sim_time_s" not in result.info


@pytest.mark.parametrize("skill", sorted(CASES))
def test_is_valid_agrees_with_run_trial(backend: Kitchen2DBackend, skill: str) -> None:
    rng = np.random.default_rng(7)
    spec = backend.skills()[skill]
    context = backend.sample_context(skill, rng)
    controls = spec.control.sample_uniform(rng, 400)
    mask = backend.is_valid(skill, context, controls)
    assert mask.shape == (400,) and 0.3 < mask.mean() < 1.0
    for control in controls[~mask][:5]:
        assert not backend.run_trial(skill, context, control, 0).valid


def test_sample_context_in_paper_ranges(backend: Kitchen2DBackend) -> None:
    rng = np.random.default_rng(0)
    pour = np.array([backend.sample_context("pour", rng) for _ in range(200)])
    assert pour[:, [0, 2]].min() >= 3 and pour[:, [0, 2]].max() <= 8
    assert pour[:, [1, 3]].min() >= 3 and pour[:, [1, 3]].max() <= 5
    scoop = np.array([backend.sample_context("scoop", rng) for _ in range(200)])
    assert scoop[:, 0].min() >= 5 and scoop[:, 0].max() <= 10
    assert scoop[:, 1].min() >= 4 and scoop[:, 1].max() <= 8


def test_trial_is_deterministic_given_seed_whatever_ran_before(
    backend: Kitchen2DBackend,
) -> None:
    context, good, _ = (np.array(v) for v in CASES["pour"])
    first = backend.run_trial("pour", context, good, 5)
    backend.run_trial("scoop", np.array(CASES["scoop"][0]), np.array(CASES["scoop"][1]), 1)
    again = backend.run_trial("pour", context, good, 5)
    assert first == again


def test_render_trial_writes_gif_and_matches_plain_run(backend: Kitchen2DBackend, tmp_path) -> None:
    context, good, _ = (np.array(v) for v in CASES["push"])
    path = tmp_path / "push.gif"
    result, frames = render_trial("push", context, good, 0, path, every=10, scale=10)
    assert result == backend.run_trial("push", context, good, 0)
    assert len(frames) > 5 and path.stat().st_size > 0
    assert frames[0].tobytes() != frames[-1].tobytes()  # the block moved
