"""Issue #5: the adaptive sampler has no false-positive bias relative to uniform sampling of Â.

Both rejection and adaptive sampling target the uniform distribution on ``Â_α`` (the paper:
"as n → ∞ ... sampling uniformly at random from Â"), so their expected false-positive rate
is the share of ``Â_α`` where the true score is ``≤ 0``. Measured here on an 8-D skill context
whose set holds several percent of bad controls, against a large uniform estimate.
"""

from __future__ import annotations

import numpy as np
import pytest

from ltamp_cli.sampling.factory import make_sampler
from ltamp_cli.sampling.superlevel import build_superlevel_set

SKILL = "skill8d"


def _fp_prone_context(synthetic, model):
    """The first seeded context whose set has >= 2% bad controls (by 200k uniform draws)."""
    for seed in range(40):
        context = synthetic.sample_context(SKILL, np.random.default_rng([31, seed]))
        superlevel = build_superlevel_set(model, context, np.random.default_rng(seed), lam=0.99)
        u = np.random.default_rng([5, seed]).uniform(-1, 1, (200_000, superlevel.dim))
        members = u[superlevel.contains(u)]
        if len(members) < 2000:
            continue
        scores = synthetic.true_score(SKILL, context, superlevel.to_physical(members))
        rate = float(np.mean(scores <= 0.0))
        if rate >= 0.02:
            return context, superlevel.beta, rate
    raise AssertionError("no context with false positives in its set")


@pytest.mark.slow
def test_adaptive_false_positive_rate_is_the_uniform_one(synthetic, skill8d_model) -> None:
    context, beta, uniform_rate = _fp_prone_context(synthetic, skill8d_model)
    rates = {}
    for name in ("rejection", "adaptive"):
        bad = total = 0
        for run in range(40):  # 40 independent runs of 50 samples, as the FP metric draws
            sampler = make_sampler(name, skill8d_model, context,
                                   np.random.default_rng([run, 17]), beta=beta)
            controls = np.array([c for _, c in zip(range(50), sampler, strict=False)])
            assert len(controls) == 50
            scores = synthetic.true_score(SKILL, context, controls)
            bad += int(np.sum(scores <= 0.0))
            total += len(scores)
        rates[name] = bad / total
    # binomial standard error of 2,000 uniform samples; 4 of them (samples from one adaptive
    # pool are not independent, which widens its spread a little)
    tolerance = 4.0 * np.sqrt(uniform_rate * (1.0 - uniform_rate) / 2000)
    assert abs(rates["rejection"] - uniform_rate) <= tolerance, (rates, uniform_rate)
    assert abs(rates["adaptive"] - uniform_rate) <= tolerance, (rates, uniform_rate)
