"""The four samplers: membership of every sample, FP, uniformity, diversity, kernel learning."""

from __future__ import annotations

import numpy as np
import pytest

from ltamp_cli.learning.confidence import relaxed_beta
from ltamp_cli.sampling.adaptive import AdaptiveSampler
from ltamp_cli.sampling.factory import SAMPLER_NAMES, make_sampler
from ltamp_cli.sampling.kernel_learning import (
    MIN_INVERSE_LENGTHSCALE,
    DiversityKernel,
    diversity,
)
from ltamp_cli.sampling.metrics import false_positive_rate
from ltamp_cli.sampling.superlevel import build_superlevel_set


def _valid8d(synthetic):
    return lambda context, controls: synthetic.is_valid("skill8d", context, controls)


def _draw(sampler, n: int) -> np.ndarray:
    return np.array([next(sampler) for _ in range(n)])


def test_superlevel_set_membership_agrees_with_the_model(synthetic, skill8d_model) -> None:
    context = np.array([0.3, 1.2, 0.1, 2.0])
    superlevel = build_superlevel_set(
        skill8d_model, context, np.random.default_rng(0), is_valid=_valid8d(synthetic)
    )
    assert superlevel.beta == pytest.approx(relaxed_beta(superlevel.phi_star, 0.95))
    u = np.random.default_rng(1).uniform(-1, 1, (5000, 4))
    controls = superlevel.to_physical(u)
    mean, std = skill8d_model.predict(context, controls)
    expected = (mean / std > superlevel.beta) & synthetic.is_valid("skill8d", context, controls)
    inside = superlevel.contains(u)
    assert 0 < inside.sum() < len(u)
    assert np.array_equal(inside, expected)
    star = superlevel.to_physical(superlevel.theta_star)
    assert synthetic.is_valid("skill8d", context, star)[0]


@pytest.mark.parametrize("name", SAMPLER_NAMES)
def test_every_sample_is_in_the_set_and_valid(synthetic, skill8d_model, name: str) -> None:
    context = np.array([0.9, 0.4, -0.6, 4.0])
    for seed in range(3):
        sampler = make_sampler(name, skill8d_model, context, np.random.default_rng(seed),
                               is_valid=_valid8d(synthetic))
        controls = _draw(sampler, 120)
        assert controls.shape == (120, 4)
        mean, std = skill8d_model.predict(context, controls)
        assert np.all(mean / std > sampler.beta)
        assert np.all(synthetic.is_valid("skill8d", context, controls))
        space = skill8d_model.spec.control
        lows, highs = space.low_array(), space.high_array()
        assert np.all((controls >= lows) & (controls <= highs))
        assert len(np.unique(controls, axis=0)) == len(controls)


@pytest.mark.parametrize("name", ["rejection", "adaptive", "diverse"])
def test_no_false_positives_when_trained_densely(synthetic, moving2d_model, name: str) -> None:
    rates = []
    for seed, phase in enumerate([0.1, 0.5, 0.9]):
        context = np.array([phase])
        sampler = make_sampler(name, moving2d_model, context, np.random.default_rng(seed), lam=0.99)
        controls = _draw(sampler, 50)
        rates.append(false_positive_rate(synthetic.true_score("moving2d", context, controls)))
    # diverse picks far-apart members, nearer the set's boundary: slightly more FPs (paper)
    assert max(rates) <= (0.06 if name == "diverse" else 0.02)
    assert np.mean(rates) <= 0.03


def test_adaptive_is_uniform_over_the_set_like_rejection(synthetic, toy1d_model) -> None:
    """Importance weights make the adaptive samples spread like uniform ones over Â."""
    context = np.zeros(0)
    rejection = _draw(make_sampler("rejection", toy1d_model, context, np.random.default_rng(0)),
                      1500)
    adaptive = _draw(make_sampler("adaptive", toy1d_model, context, np.random.default_rng(0)),
                     1500)
    # toy1d's good set is two intervals, split at θ = 0.5
    share_rejection = np.mean(rejection[:, 0] < 0.5)
    share_adaptive = np.mean(adaptive[:, 0] < 0.5)
    assert 0.1 < share_rejection < 0.9
    assert abs(share_adaptive - share_rejection) < 0.06
    assert abs(np.quantile(adaptive, 0.5) - np.quantile(rejection, 0.5)) < 0.05


def test_adaptive_scale_shrinks_for_a_small_set(moving2d_model) -> None:
    superlevel = build_superlevel_set(moving2d_model, np.array([0.0]), np.random.default_rng(0))
    sampler = AdaptiveSampler(superlevel, np.random.default_rng(1))
    start = sampler.scale.copy()
    _draw(sampler, 200)
    # the disc covers < 10% of the box at phase 0: TGMM acceptance below n/10 halves the scale
    assert np.all(sampler.scale < start)


def test_diverse_beats_adaptive_on_diversity(synthetic, skill8d_model) -> None:
    gains = []
    for seed in range(8):
        context = synthetic.sample_context("skill8d", np.random.default_rng(100 + seed))
        values = {}
        for name in ("adaptive", "diverse"):
            sampler = make_sampler(name, skill8d_model, context, np.random.default_rng(seed))
            unit = sampler.superlevel.to_unit(_draw(sampler, 5))
            values[name] = diversity(unit)
        gains.append(values["diverse"] - values["adaptive"])
    assert np.mean(gains) > 0.5
    assert np.mean(np.array(gains) > 0) >= 0.75


def test_kernel_update_shrinks_the_most_different_feature() -> None:
    kernel = DiversityKernel.unit(3)
    selected = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.05]])
    theta = np.array([0.05, 0.9, 0.0])  # differs from S along feature 1 only
    importance = kernel.feature_importance(theta, selected)
    assert int(np.argmax(importance)) == 1
    assert kernel.update(theta, selected) == 1
    assert kernel.inverse_lengthscales == pytest.approx([1.0, 0.7, 1.0])
    assert kernel.update(theta, np.empty((0, 3))) is None
    assert kernel.updates == 1


def test_kernel_learning_stops_at_the_floor_instead_of_collapsing() -> None:
    """Hundreds of unusable reports (a hard problem) leave every l_d at the floor, never 0."""
    kernel = DiversityKernel.unit(3)
    rng = np.random.default_rng(5)
    shrunk = [kernel.update(rng.random(3), rng.random((4, 3))) for _ in range(400)]
    assert np.all(kernel.inverse_lengthscales == pytest.approx(MIN_INVERSE_LENGTHSCALE))
    assert shrunk[-1] is None  # nothing left to learn: the report is ignored
    # Each feature needs ceil(log(floor) / log(1 - eps)) steps to reach the floor.
    steps = int(np.ceil(np.log(MIN_INVERSE_LENGTHSCALE) / np.log(1.0 - kernel.epsilon)))
    assert kernel.updates == 3 * steps
    # A feature already at the floor is passed over for the next most important one.
    kernel = DiversityKernel(np.array([MIN_INVERSE_LENGTHSCALE, 1.0, 1.0]))
    selected = np.array([[0.0, 0.0, 0.0], [0.0, 0.1, 0.0]])
    assert kernel.update(np.array([0.9, 0.05, 0.3]), selected) == 2


def test_diverse_lk_uses_the_learned_kernel_after_feedback(skill8d_model) -> None:
    context = np.array([0.5, 1.0, 0.0, 2.5])

    def run(feedback: bool) -> tuple[np.ndarray, DiversityKernel]:
        kernel = DiversityKernel.unit(4)
        sampler = make_sampler("diverse-lk", skill8d_model, context, np.random.default_rng(7),
                               kernel=kernel)
        drawn = [next(sampler) for _ in range(3)]
        if feedback:
            for _ in range(4):  # the same sample reported repeatedly
                assert sampler.report_unusable(drawn[2]) is not None
        drawn += [next(sampler) for _ in range(6)]
        return np.array(drawn), kernel

    plain, unchanged = run(False)
    learned, kernel = run(True)
    assert unchanged.updates == 0 and kernel.updates == 4
    assert np.all(kernel.inverse_lengthscales <= 1.0)
    assert kernel.inverse_lengthscales.min() < 0.5
    assert np.array_equal(plain[:3], learned[:3])
    assert not np.array_equal(plain[3:], learned[3:])


def test_diverse_lk_selection_is_the_argmax_under_the_updated_kernel(skill8d_model) -> None:
    context = np.array([0.5, 1.0, 0.0, 2.5])
    kernel = DiversityKernel(np.array([1.0, 0.1, 1.0, 0.05]))
    sampler = make_sampler("diverse-lk", skill8d_model, context, np.random.default_rng(3),
                           kernel=kernel)
    for _ in range(4):
        next(sampler)
    sampler._ensure_buffer()
    candidates = np.array(sampler.buffer)
    expected = candidates[np.argmax(kernel.conditional_variance(candidates, sampler.selected))]
    chosen = sampler.superlevel.to_unit(next(sampler))[0]
    assert np.allclose(chosen, expected)


def test_fixed_diverse_ignores_feedback(skill8d_model) -> None:
    sampler = make_sampler("diverse", skill8d_model, np.array([0.5, 1.0, 0.0, 2.5]),
                           np.random.default_rng(0))
    first, second = next(sampler), next(sampler)
    assert sampler.report_unusable(second) is None
    assert sampler.kernel.updates == 0
    assert first.shape == (4,)


def test_unknown_sampler_and_non_gp_model(skill8d_model) -> None:
    with pytest.raises(ValueError, match="unknown sampler"):
        make_sampler("mcmc", skill8d_model, np.zeros(4), np.random.default_rng(0))
    from ltamp_cli.learning.baselines import RandomModel

    with pytest.raises(TypeError, match="GP"):
        make_sampler("adaptive", RandomModel(skill8d_model.spec, 0.0), np.zeros(4),
                     np.random.default_rng(0))
