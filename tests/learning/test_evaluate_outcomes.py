"""``ltamp evaluate``'s per-context outcomes (issue #21): what pairs two models' evaluations.

``_live_outcomes`` lists, per context drawn from the seed, whether θ* and a random valid
control succeeded, and the contexts themselves. Two models evaluated at one seed must meet the
same contexts (the refit comparison in ``bench/gpprior_refit2d.py`` relies on it). Box2D push
with stand-in models: pushing away from the goal leaves the object at the origin, so θ*
succeeds exactly for the goals within 2 of it; a model that does not push at all likewise.
"""

from __future__ import annotations

import math

import numpy as np

from ltamp_cli.backends.box2d.backend import Kitchen2DBackend
from ltamp_cli.cli.evaluate import _live_outcomes, _live_success_rates


class _Fixed:
    """A stand-in model whose θ* is one fixed control, drawing candidates like a GP's."""

    def __init__(self, control: list[float]) -> None:
        self.control = np.array(control)

    def most_confident_control(self, context: np.ndarray, rng: np.random.Generator,
                               is_valid: object) -> tuple[np.ndarray, float]:
        rng.uniform(size=(100, 4))  # θ*'s search consumes a fixed number of draws
        return self.control, 0.0


def test_per_context_outcomes_are_paired_by_seed_and_match_the_rates() -> None:
    backend = Kitchen2DBackend()
    try:
        away = _Fixed([-2.0, 0.0, math.pi, 0.5])
        still = _Fixed([-4.0, 4.0, 0.0, 0.0])  # zero duration: the object is not touched
        star, baseline, contexts = _live_outcomes(backend, "push", away, 30, 4)
        star2, baseline2, contexts2 = _live_outcomes(backend, "push", still, 30, 4)
        assert contexts == contexts2 and baseline == baseline2
        near = [int(np.linalg.norm(c) < 2.0) for c in contexts]
        assert star == near and star2 == near
        assert 0 < sum(near) < 30  # both outcomes occur
        assert len(contexts) == 30 and all(len(c) == 2 for c in contexts)
        assert _live_success_rates(backend, "push", away, 30, 4) == (
            sum(star) / 30, sum(baseline) / 30)
        assert _live_outcomes(backend, "push", away, 0, 4) == ([], [], [])
    finally:
        backend.close()
