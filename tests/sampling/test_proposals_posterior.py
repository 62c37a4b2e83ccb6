"""Proposal densities and samples, and the per-context posterior against the model's own."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import truncnorm

from ltamp_cli.sampling.posterior import ContextPosterior
from ltamp_cli.sampling.proposals import TruncatedGaussianMixture, UniformBox


def _box(d: int) -> tuple[np.ndarray, np.ndarray]:
    return -np.ones(d), np.ones(d)


def test_tgmm_samples_stay_in_the_box_and_follow_truncnorm() -> None:
    lows, highs = _box(2)
    tgmm = TruncatedGaussianMixture(
        np.array([[0.9, -0.5]]), np.array([0.3, 2.0]), np.ones(1), lows, highs
    )
    x = tgmm.sample(np.random.default_rng(0), 100_000)
    assert np.all((x >= -1) & (x <= 1))
    a, b = (lows - [0.9, -0.5]) / [0.3, 2.0], (highs - [0.9, -0.5]) / [0.3, 2.0]
    expected_mean = [truncnorm.mean(a[i], b[i], [0.9, -0.5][i], [0.3, 2.0][i]) for i in range(2)]
    # standard error of the mean is < 0.004 for both dimensions
    assert np.allclose(x.mean(0), expected_mean, atol=0.015)
    reference = sum(
        truncnorm.logpdf(x[:100, i], a[i], b[i], [0.9, -0.5][i], [0.3, 2.0][i]) for i in range(2)
    )
    assert np.allclose(tgmm.log_density(x[:100]), reference, rtol=1e-9)


def test_tgmm_far_tail_is_truly_truncated() -> None:
    # The Gaussian's mass in the box is ~e^-800: clipping would pile samples on the edge.
    tgmm = TruncatedGaussianMixture(np.array([[5.0]]), np.array([0.1]), np.ones(1), *_box(1))
    x = tgmm.sample(np.random.default_rng(1), 50_000)[:, 0]
    assert x.max() <= 1.0 and x.min() > 0.9
    assert np.mean(x == 1.0) < 0.01
    # exponential tail with rate 40/0.1 = 400 from the edge: mean offset 1/400
    assert abs((1.0 - x.mean()) - 1.0 / 400.0) < 2e-4
    assert np.isfinite(tgmm.log_density(np.array([[0.99]])))[0]


def test_mixture_density_integrates_to_one() -> None:
    rng = np.random.default_rng(2)
    lows, highs = _box(3)
    tgmm = TruncatedGaussianMixture(
        rng.uniform(-1, 1, (4, 3)), np.array([0.2, 0.5, 1.0]), np.array([1.0, 2.0, 3.0, 4.0]),
        lows, highs,
    )
    box = UniformBox.unit(3)
    u = box.sample(rng, 400_000)
    integral = box.volume * np.exp(tgmm.log_density(u)).mean()
    assert integral == pytest.approx(1.0, abs=0.02)
    assert np.all(np.isneginf(tgmm.log_density(np.array([[1.5, 0.0, 0.0]]))))
    assert box.log_density(u[:3]) == pytest.approx([-np.log(8.0)] * 3)


@pytest.mark.parametrize("kernel", ["rbf", "matern52", "mlp"])
def test_context_posterior_matches_the_model(synthetic, fit, kernel: str) -> None:
    model = fit(synthetic, "skill8d", 60, seed=4, kernel=kernel)
    rng = np.random.default_rng(5)
    context_unit = rng.uniform(-1, 1, 4)
    posterior = ContextPosterior(model, context_unit)
    assert posterior.fast == (kernel != "mlp")
    u = rng.uniform(-1, 1, (3000, 4))
    mean, std = posterior.predict(u)
    ref_mean, ref_std = model.predict_normalized(np.hstack([u, np.tile(context_unit, (3000, 1))]))
    assert np.allclose(mean, ref_mean, rtol=1e-7, atol=1e-9)
    assert np.allclose(std, ref_std, rtol=1e-6, atol=1e-9)
