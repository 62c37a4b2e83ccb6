"""Straddle, the box maximiser, θ*, β* and the relaxed β."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import norm

from ltamp_cli.learning.acquisition import confidence_ratio, maximize, straddle
from ltamp_cli.learning.confidence import beta_star, relaxed_beta
from ltamp_cli.learning.gp import fit_gp
from ltamp_cli.learning.model import LevelSetModel


def test_straddle_formula():
    np.testing.assert_allclose(
        straddle(np.array([-1.0, 0.0, 2.0]), np.array([1.0, 0.5, 0.1])),
        [-1.0 + 1.96, 0.98, -2.0 + 0.196],
    )


@pytest.fixture(scope="module")
def bump_gp():
    # A bump centred at (0.3, -0.2): μ is largest there.
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (80, 2))
    y = 1.0 - 4.0 * ((x[:, 0] - 0.3) ** 2 + (x[:, 1] + 0.2) ** 2)
    return fit_gp(x, y, "rbf", rng=rng)


def test_maximize_finds_the_bump_and_respects_fixed_coordinates(bump_gp):
    rng = np.random.default_rng(1)
    best = maximize(bump_gp, lambda m, s: m, rng, n_candidates=2000)
    np.testing.assert_allclose(best.x, [0.3, -0.2], atol=0.03)
    fixed = maximize(
        bump_gp,
        lambda m, s: m,
        rng,
        fixed=np.array([0.0, 0.7]),
        free=np.array([True, False]),
        n_candidates=500,
    )
    assert fixed.x[1] == 0.7 and abs(fixed.x[0] - 0.3) < 0.05


def test_maximize_respects_the_validity_test(bump_gp):
    rng = np.random.default_rng(2)
    best = maximize(
        bump_gp, lambda m, s: m, rng, n_candidates=2000, is_valid=lambda x: x[:, 0] < 0.0
    )
    assert best.x[0] < 0.0 and abs(best.x[1] + 0.2) < 0.1
    assert (
        maximize(bump_gp, lambda m, s: m, rng, n_candidates=100, is_valid=lambda x: x[:, 0] > 5)
        is None
    )


def test_beta_star_follows_corollary_1():
    assert math.isclose(beta_star(0.05, count=50), math.sqrt(2 * math.log(50 / 0.1)))
    assert math.isclose(beta_star(0.1, index=3), math.sqrt(2 * math.log(math.pi**2 * 9 / 6 / 0.2)))
    assert beta_star(0.05, index=10) > beta_star(0.05, index=1)
    with pytest.raises(ValueError):
        beta_star(1.5, count=3)
    with pytest.raises(ValueError):
        beta_star(0.1)


@pytest.mark.parametrize("phi", [-1.0, 0.3, 2.0, 9.0])
@pytest.mark.parametrize("lam", [0.95, 0.99, 0.999])
def test_relaxed_beta_is_the_lambda_quantile(phi, lam):
    beta = relaxed_beta(phi, lam)
    assert math.isclose(norm.cdf(beta), lam * norm.cdf(phi), rel_tol=1e-9)
    assert beta < phi


def test_relaxed_beta_rejects_lambda_outside_the_papers_range():
    with pytest.raises(ValueError):
        relaxed_beta(1.0, 0.5)


def test_most_confident_control_lies_in_the_true_level_set(synthetic):
    spec = synthetic.skills()["moving2d"]
    rng = np.random.default_rng(3)
    contexts = spec.context.sample_uniform(rng, 150)
    controls = spec.control.sample_uniform(rng, 150)
    scores = synthetic.true_score("moving2d", contexts, controls)
    model = LevelSetModel.fit(spec, contexts, controls, scores, "matern52", seed=3)
    # Inputs are [control..., context...] normalised to [-1, 1].
    x = np.c_[(controls - [2.0, 0.0]) / [2.0, 1.0], contexts * 2 - 1]
    np.testing.assert_allclose(model.gp.x_np, x)
    for phase in (0.1, 0.5, 0.9):
        theta, phi = model.most_confident_control(np.array([phase]), rng)
        assert synthetic.true_score("moving2d", [phase], theta[None, :])[0] > 0
        mean, std = model.predict(np.array([phase]), theta[None, :])
        assert math.isclose(phi, mean[0] / std[0], rel_tol=1e-6)
        assert model.beta(np.array([phase]), 0.95, rng) < phi
    # A validity test that forbids the right half of x is obeyed.
    theta, _ = model.most_confident_control(np.array([0.0]), rng, lambda c, u: u[:, 0] < 2.0)
    assert theta[0] < 2.0
    assert confidence_ratio(np.array([2.0]), np.array([4.0]))[0] == 0.5
