"""A GP's fit does not depend on the unit of the scores: only their sign decides success.

Round 7: scores whose RMS was at most 1e-12 were left in score units (the scale fell back
to 1), where the noise floor and the outputscale bounds swallowed them: a model of the same
25 trials scoring ±1e-13 instead of ±1 had μ/σ = 1.4e-10 (was 3.0) at the centre of its
success region and β = -0.06 (was 1.64): it had learned nothing, and sampled anywhere.
"""

from __future__ import annotations

import numpy as np
import pytest

from ltamp_cli.backends.protocol import ParamSpace, SkillSpec
from ltamp_cli.learning.gp import fit_gp
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.sampling.factory import make_sampler

SPEC = SkillSpec("tiny", ParamSpace(("a",), (0.0,), (1.0,)),
                 ParamSpace(("u", "v"), (0.0, 0.0), (1.0, 1.0)), deterministic=True)


def _trials(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``n`` trials of a disc of success (radius 0.3 around the controls' centre)."""
    rng = np.random.default_rng(0)
    contexts, controls = rng.uniform(0, 1, (n, 1)), rng.uniform(0, 1, (n, 2))
    scores = np.where(np.hypot(controls[:, 0] - 0.5, controls[:, 1] - 0.5) < 0.3, 1.0, -1.0)
    return contexts, controls, scores


def _ratio_and_beta(unit: float, kernel: str) -> tuple[float, float]:
    contexts, controls, scores = _trials(25)
    model = LevelSetModel.fit(SPEC, contexts, controls, scores * unit, kernel=kernel)
    mean, std = model.predict(np.array([[0.5]]), np.array([[0.5, 0.5]]))
    return float(mean[0] / std[0]), model.beta(np.array([0.5]), rng=np.random.default_rng(0))


@pytest.mark.parametrize("kernel", ["matern52", "rbf"])
def test_the_fit_is_the_same_in_any_unit(kernel: str) -> None:
    ratio, beta = _ratio_and_beta(1.0, kernel)
    assert ratio > 2.0 and beta > 1.0  # the disc is learned
    for unit in (1e-12, 1e-13, 1e-30, 1e-200, 1e-310):
        tiny_ratio, tiny_beta = _ratio_and_beta(unit, kernel)
        # before: μ/σ ≈ 1e-10 · (unit / 1e-13), β -0.06 for every unit at or below 1e-12
        assert tiny_ratio == pytest.approx(ratio, rel=1e-6), unit
        assert tiny_beta == pytest.approx(beta, rel=1e-6), unit


def test_zero_scores_keep_a_unit_scale() -> None:
    gp = fit_gp(np.random.default_rng(0).uniform(0, 1, (5, 2)), np.zeros(5))
    assert gp.y_scale == 1.0
    mean, std = gp.predict(np.array([[0.5, 0.5]]))
    assert mean[0] == pytest.approx(0.0, abs=1e-12) and np.isfinite(std[0])


def test_tiny_scores_sample_the_learned_set() -> None:
    contexts, controls, scores = _trials(40)
    model = LevelSetModel.fit(SPEC, contexts, controls, scores * 1e-13, kernel="matern52")
    sampler = make_sampler("adaptive", model, np.array([0.5]), np.random.default_rng(1))
    samples = np.array([next(sampler) for _ in range(20)])
    inside = np.hypot(samples[:, 0] - 0.5, samples[:, 1] - 0.5) < 0.3
    assert inside.mean() >= 0.8  # before: ~0.3 (the disc's area: uniform guesses)
