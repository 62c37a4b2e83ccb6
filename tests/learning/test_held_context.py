"""Issue #21 (push active learning) options: held contexts for ``lse`` and a lengthscale cap."""

from __future__ import annotations

import numpy as np
import pytest

from ltamp_cli.learning.active import LearningConfig, fit_model, gp_bounds, learn_online
from ltamp_cli.learning.gp import HyperBounds


def test_lse_with_context_repeats_keeps_each_drawn_context_for_k_trials(synthetic):
    config = LearningConfig(strategy="lse", budget=21, init=5, seed=2, context_repeats=4,
                            explore_until_success=False)
    records = learn_online(synthetic, "moving2d", config).records
    contexts = [r.context for r in records[5:]]
    runs = [contexts[i:i + 4] for i in range(0, 16, 4)]
    assert all(len(set(run)) == 1 for run in runs), runs
    assert len({run[0] for run in runs}) == 4  # a new draw after every k trials
    # The default (joint straddle) chooses a context per trial.
    joint = learn_online(synthetic, "moving2d", LearningConfig(
        strategy="lse", budget=21, init=5, seed=2, explore_until_success=False)).records
    assert len({r.context for r in joint[5:9]}) > 1


def test_lengthscale_max_bounds_every_fitted_lengthscale(synthetic):
    spec = synthetic.skills()["moving2d"]
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, size=(40, spec.control.dim + spec.context.dim))
    y = np.sin(2.0 * x[:, 0])  # the other inputs are irrelevant: long lengthscales uncapped
    free = fit_model(spec, LearningConfig(strategy="gp", lengthscale_prior_sd=None), x, y)
    assert free.gp.lengthscales.max() > 1.0, free.gp.lengthscales
    capped = fit_model(spec, LearningConfig(strategy="gp", lengthscale_prior_sd=None,
                                            lengthscale_max=0.3), x, y)
    assert capped.gp.lengthscales.max() <= 0.3 + 1e-9, capped.gp.lengthscales


def test_gp_bounds_cap_keeps_the_noise_rule(synthetic):
    spec = synthetic.skills()["moving2d"]
    assert gp_bounds(spec) == HyperBounds(noise=gp_bounds(spec).noise)
    capped = gp_bounds(spec, 0.16)
    assert capped.lengthscale == (HyperBounds().lengthscale[0], 0.16)
    assert capped.noise == gp_bounds(spec).noise


def test_bad_options_are_rejected():
    with pytest.raises(ValueError, match="context_repeats"):
        LearningConfig(context_repeats=-1)
    with pytest.raises(ValueError, match="lengthscale_max"):
        LearningConfig(lengthscale_max=0.01)
    with pytest.raises(ValueError, match="lengthscale_max"):
        LearningConfig(lengthscale_max=50.0)
