"""Issue #21: the GP fit's lengthscale prior (MAP) keeps the controls in the model.

With few successes among many failures that all score the same, the maximum marginal
likelihood fit called the controls irrelevant (their lengthscales at the upper bound 20) and
explained the successes by short context lengthscales; θ* (argmax μ/σ over controls) was then
arbitrary. ``bench.lse2``'s ``saturated4d`` skill, ``lse2``, seed 1, 100 trials, θ* over 100
held-out contexts: 0.01 with the old fit (``lengthscale_prior_sd=None``; also
``docs/results/learning/lse2-runs.jsonl``), 1.00 with the default prior. The threshold 0.5 is
far from both. Both runs keep ``lse2``'s largest-ψ choice on fully classified slices
(``lse2_uniform_if_classified=False``): that later fix alone also rescues the old fit here
(``tests/learning/test_lse2_classified_slice.py``). The gradient test checks the hand-written
prior term against finite differences.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bench.lse2 import saturated_backend
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.gp import DEFAULT_PRIOR, LengthscalePrior, fit_gp


def _theta_star_success(prior_sd: float | None, seed: int = 1, fallback: bool = False) -> float:
    """θ* success of ``lse2`` (``fallback``: ``lse2_uniform_if_classified``, off by default
    here so that the prior's effect is measured alone)."""
    backend = saturated_backend()
    config = LearningConfig(strategy="lse2", budget=100, init=10, seed=seed,
                            lengthscale_prior_sd=prior_sd, lse2_uniform_if_classified=fallback)
    model = learn_online(backend, "saturated4d", config).model
    rng = np.random.default_rng([2025, 11])
    contexts = np.array([backend.sample_context("saturated4d", rng) for _ in range(100)])

    def is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return backend.is_valid("saturated4d", context, controls)

    hits = 0
    for context in contexts:
        control, _ = model.most_confident_control(context, np.random.default_rng(0), is_valid,
                                                  n_candidates=2000)
        hits += int(backend.true_score("saturated4d", context, control[None])[0] > 0)
    return hits / len(contexts)


def test_lse2_with_the_prior_learns_the_saturated_skill():
    assert LearningConfig().lengthscale_prior_sd == DEFAULT_PRIOR.log_sd
    assert _theta_star_success(LearningConfig().lengthscale_prior_sd) > 0.5


@pytest.mark.slow
def test_the_old_fit_fails_there():
    # Documents the failure the default prior fixes (also a check that the test above can fail).
    assert _theta_star_success(None) < 0.5


@pytest.mark.parametrize("kernel", ["matern52", "rbf"])
def test_prior_gradient_matches_finite_differences(kernel):
    prior = LengthscalePrior(0.7, 0.8)
    rng = np.random.default_rng(3)
    dim = 3
    params = rng.uniform(-2, 2, dim)
    value, gradient = prior.penalty_and_gradient(kernel, params, dim)
    assert value >= 0
    for i in range(params.size):
        step = np.zeros(params.size)
        step[i] = 1e-6
        up = prior.penalty_and_gradient(kernel, params + step, dim)[0]
        down = prior.penalty_and_gradient(kernel, params - step, dim)[0]
        assert gradient[i] == pytest.approx((up - down) / 2e-6, rel=1e-5, abs=1e-8)
    assert prior.penalty_and_gradient("mlp", np.r_[params, 0.0], dim)[0] == 0.0


def test_the_prior_is_weak_against_clear_data():
    # y depends on x0 only, noise-free, 40 points: the data clearly call x1 irrelevant, and
    # the prior (4.5 nats at the bound) does not override them; ℓ0 stays short.
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (40, 2))
    y = np.sin(4.0 * x[:, 0])
    ml = fit_gp(x, y, rng=np.random.default_rng(0), prior=None)
    mapped = fit_gp(x, y, rng=np.random.default_rng(0))
    for gp in (ml, mapped):
        assert gp.lengthscales[0] < 1.0 and gp.lengthscales[1] > 10.0
    # nll is the likelihood term alone: the MAP point cannot beat the ML optimum on it
    assert math.isfinite(mapped.nll) and mapped.nll >= ml.nll - 1e-6


def test_the_prior_moves_unidentified_lengthscales_towards_its_median():
    # Few saturated failures and two successes (the pour's pattern): ML calls some inputs
    # irrelevant (ℓ = 20, the bound); with the prior no lengthscale reaches the bound.
    rng = np.random.default_rng(4)
    x = rng.uniform(-1, 1, (30, 4))
    y = np.full(30, -1.0)
    y[:2] = 1.5
    ml = fit_gp(x, y, rng=np.random.default_rng(0), prior=None)
    mapped = fit_gp(x, y, rng=np.random.default_rng(0))
    assert ml.lengthscales.max() > 19.0
    assert mapped.lengthscales.max() < 15.0


def test_bad_prior_is_rejected():
    with pytest.raises(ValueError):
        LengthscalePrior(0.0, 1.0)
    with pytest.raises(ValueError):
        LearningConfig(lengthscale_prior_sd=0.0)
