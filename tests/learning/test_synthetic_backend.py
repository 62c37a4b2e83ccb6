"""The synthetic backend: protocol conformance and its known super-level sets."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from ltamp_cli.backends import SkillBackend, load_backend
from ltamp_cli.errors import InputError


def test_conforms_to_protocol_and_lists_the_three_skills(synthetic):
    assert isinstance(synthetic, SkillBackend)
    specs = synthetic.skills()
    assert set(specs) == {"toy1d", "moving2d", "skill8d", "flick2d"}
    assert (specs["toy1d"].control.dim, specs["toy1d"].context.dim) == (1, 0)
    assert (specs["moving2d"].control.dim, specs["moving2d"].context.dim) == (2, 1)
    assert (specs["skill8d"].control.dim, specs["skill8d"].context.dim) == (4, 4)


def test_toy1d_has_two_positive_intervals(synthetic):
    theta = np.linspace(0, 1, 10001)
    scores = synthetic.true_score("toy1d", np.zeros((len(theta), 0)), theta[:, None])
    crossings = np.flatnonzero(np.diff(np.sign(scores)))
    assert len(crossings) == 4

    def g(t: float) -> float:
        return 0.8 * math.sin(3 * math.pi * t) * math.exp(-t) - 0.2

    first = brentq(g, 0.0, 1 / 6)
    assert scores[int(first * 10000) + 2] > 0 > scores[int(first * 10000) - 2]


def test_moving2d_good_disc_moves_with_the_phase(synthetic):
    # phase 0: centre u = (0.45, 0) -> x = 2.9, y = 0; phase 1: u = (-0.45, 0) -> x = 1.1.
    assert synthetic.true_score("moving2d", [0.0], [[2.9, 0.0]])[0] > 0
    assert synthetic.true_score("moving2d", [1.0], [[2.9, 0.0]])[0] < 0
    assert synthetic.true_score("moving2d", [1.0], [[1.1, 0.0]])[0] > 0
    assert synthetic.true_score("moving2d", [0.0], [[1.1, 0.0]])[0] < 0


def test_skill8d_invalid_corner_is_not_simulated(synthetic):
    context = np.array([0.5, 1.0, 0.0, 2.5])
    corner = np.array([1.0, 10.0, 0.5, 0.0])  # u0 + u1 = 2 > 1.2
    assert not synthetic.is_valid("skill8d", context, corner[None, :])[0]
    result = synthetic.run_trial("skill8d", context, corner, seed=1)
    assert result.valid is False and result.score == -1.0
    assert synthetic.true_score("skill8d", context, corner[None, :])[0] == -1.0


def test_noise_is_seeded():
    noisy = load_backend("synthetic", noise=0.1)
    a = noisy.run_trial("moving2d", np.array([0.5]), np.array([2.0, 0.0]), seed=7).score
    b = noisy.run_trial("moving2d", np.array([0.5]), np.array([2.0, 0.0]), seed=7).score
    c = noisy.run_trial("moving2d", np.array([0.5]), np.array([2.0, 0.0]), seed=8).score
    assert a == b != c
    with pytest.raises(InputError):
        load_backend("synthetic", colour="red")
