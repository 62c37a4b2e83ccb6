"""Issue #21: GP-LSE2 must not chase σ into the control box's edges on a fresh context.

The skill is ``bench.lse2``'s ``saturated4d`` (2 contexts × 2 controls, a small good disc
that moves with the context, the score flat at −1 elsewhere, like the 2D pour's): each drawn
context's control slice is unexplored, so the straddle ψ there is dominated by σ. Before the
fix, ``lse2`` maximised ψ continuously (10,000 candidates, then L-BFGS-B) and put 22 of 30
and 27 of 30 of its trials on the control box's edge (some normalised coordinate with
``|u| ≥ 0.99``) for seeds 1 and 2 (49 of 60); choosing among 100 uniform valid controls puts
5 of 60 there (uniform draws alone: ~4 %). The threshold (a third) is far from both.
"""

from __future__ import annotations

import numpy as np
import pytest

from bench.lse2 import SATURATED4D, saturated_backend
from ltamp_cli.backends.synthetic import _unit
from ltamp_cli.learning.active import LearningConfig, learn_online

EDGE = 0.99


def _edge_share(seeds: tuple[int, ...]) -> tuple[int, int, int]:
    """(trials after ``init`` on the control box's edge, those trials, successes) over
    ``seeds``, 40-trial ``lse2`` runs on ``saturated4d``."""
    backend = saturated_backend()
    on_edge = total = successes = 0
    for seed in seeds:
        result = learn_online(backend, "saturated4d",
                              LearningConfig(strategy="lse2", budget=40, init=10, seed=seed))
        unit = _unit(np.array([r.control for r in result.records]), SATURATED4D.control)
        on_edge += int(np.sum(np.abs(unit[10:]).max(axis=1) >= EDGE))
        total += len(unit) - 10
        successes += sum(1 for r in result.records if r.score > 0)
    return on_edge, total, successes


def test_lse2_does_not_pile_its_trials_on_the_control_box_edges():
    on_edge, total, successes = _edge_share((1, 2))
    assert total == 60
    assert successes >= 2  # the straddle ran: explore_until_success found a success per seed
    assert on_edge < total / 3, (on_edge, total)


def test_lse2_candidates_must_be_positive():
    with pytest.raises(ValueError, match="lse2_candidates"):
        LearningConfig(lse2_candidates=0)
