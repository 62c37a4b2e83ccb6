"""Issue #20: the learned push's θ* must succeed for goals over the whole box.

The general change of the learning path, checked against the old behaviour: a deterministic
skill's GP gets almost no noise (the marginal likelihood otherwise explains the push's
needle-shaped success set as noise and ignores the push angle).

The end-to-end test fits the GP on the first 300 of the shipped push model's recorded
trials (real Box2D trials) and runs θ* live for 24 goals more than 2 units from the object
(where an unpushed object fails). Measured: with the old fit (noise bound 0.5) θ* succeeded
for 7 of these 24 goals; with the current fit for 13 of 24 (on all 500 shipped trials the
two fits come close, 17 vs 16: the aimed trials added later cover the far goals).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import torch

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.box2d.skills.push import SPEC
from ltamp_cli.learning.active import (
    DETERMINISTIC_NOISE,
    LearningConfig,
    _training_score,
    fit_model,
    gp_bounds,
)
from ltamp_cli.learning.gp import HyperBounds, fit_gp
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.learning.model_dir import spec_from_json, spec_to_json
from ltamp_cli.learning.normalize import BoxNormalizer, join_inputs, joint_space
from ltamp_cli.trials.record import TrialDataset

TRIALS = Path(__file__).resolve().parents[2] / "models" / "kitchen2d" / "push" / "trials.jsonl"


def test_deterministic_skills_get_a_small_noise_bound_and_it_round_trips() -> None:
    assert SPEC.deterministic
    assert gp_bounds(SPEC).noise[1] == DETERMINISTIC_NOISE < HyperBounds().noise[1]
    plain = spec_from_json({**spec_to_json(SPEC), "deterministic": False})
    assert gp_bounds(plain) == HyperBounds()
    assert spec_from_json(spec_to_json(SPEC)).deterministic
    # Model directories written before the flag existed load as not deterministic.
    legacy = spec_to_json(SPEC)
    del legacy["deterministic"]
    assert not spec_from_json(legacy).deterministic


def _far_goal_successes(model: LevelSetModel, backend, goals: list[np.ndarray]) -> int:
    rng = np.random.default_rng(1)
    wins = 0
    for index, goal in enumerate(goals):
        control, _ = model.most_confident_control(
            goal, rng, lambda c, u: backend.is_valid("push", c, u)
        )
        wins += backend.run_trial("push", goal, control, seed=index).score > 0
    return wins


@pytest.mark.skipif(not TRIALS.is_file(), reason="shipped push trials not present")
def test_push_theta_star_beats_the_old_fit_on_far_goals() -> None:
    torch.set_num_threads(1)
    backend = load_backend("box2d")
    try:
        records = TrialDataset(TRIALS).read()[:300]
        contexts = np.array([r.context for r in records])
        controls = np.array([r.control for r in records])
        scores = np.array([r.score for r in records])
        x = BoxNormalizer.for_space(joint_space(SPEC)).to_unit(
            join_inputs(SPEC, contexts, controls)
        )
        rng = np.random.default_rng(7)
        goals: list[np.ndarray] = []
        while len(goals) < 24:
            goal = rng.uniform(-5.0, 5.0, size=2)
            if math.hypot(*goal) > 2.0:
                goals.append(goal)
        config = LearningConfig(strategy="lse2", seed=0)
        y = np.array([_training_score(SPEC, float(s)) for s in scores])
        new = fit_model(SPEC, config, x, y, final=True, rng=np.random.default_rng(0))
        old_gp = fit_gp(x, scores, "matern52", restarts=2, rng=np.random.default_rng(0))
        old = LevelSetModel(SPEC, old_gp)
        assert isinstance(new, LevelSetModel)
        assert new.gp.noise <= DETERMINISTIC_NOISE * new.gp.y_scale**2 * (1 + 1e-6)
        new_wins = _far_goal_successes(new, backend, goals)
        old_wins = _far_goal_successes(old, backend, goals)
    finally:
        backend.close()
    # Random valid controls succeed for 0.05-1.4 % of far goals' controls (bench/push_reach.py).
    assert new_wins >= 11, (new_wins, old_wins)
    assert new_wins >= old_wins + 4, (new_wins, old_wins)
