"""The sampling bench's shared β is the one a full build gives, with far fewer validity
tests (``bench.sampling.first_valid_only``)."""

from __future__ import annotations

import numpy as np

from bench.sampling import first_valid_only
from ltamp_cli.backends import load_backend
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.sampling.superlevel import build_superlevel_set


def test_first_valid_only_keeps_theta_star_and_beta() -> None:
    backend = load_backend("synthetic")
    model = learn_online(backend, "skill8d",
                         LearningConfig(strategy="lse2", budget=20, init=10, seed=0)).model
    assert isinstance(model, LevelSetModel)
    calls = {"full": 0, "first": 0}
    skipped_invalid_top = 0

    def strict(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        # The skill's invalid corner plus half of the first control's range, so the most
        # confident candidates are often invalid and θ* is not simply the first one.
        controls = np.atleast_2d(controls)
        mid = model.spec.control.lows[0] + 0.5 * (model.spec.control.highs[0]
                                                 - model.spec.control.lows[0])
        return backend.is_valid("skill8d", context, controls) & (controls[:, 0] > mid)

    def full(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        calls["full"] += len(np.atleast_2d(controls))
        return strict(context, controls)

    def counted(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        calls["first"] += len(np.atleast_2d(controls))
        return strict(context, controls)

    for run in range(6):
        context = backend.sample_context("skill8d", np.random.default_rng([7, run]))
        a = build_superlevel_set(model, context, np.random.default_rng([11, run]), lam=0.99,
                                 is_valid=full)
        b = build_superlevel_set(model, context, np.random.default_rng([11, run]), lam=0.99,
                                 is_valid=first_valid_only(counted))
        assert a.beta == b.beta and a.phi_star == b.phi_star
        np.testing.assert_array_equal(a.theta_star, b.theta_star)
        top = build_superlevel_set(model, context, np.random.default_rng([11, run]),
                                   lam=0.99)  # no validity: θ* is the top candidate
        skipped_invalid_top += int(not np.array_equal(top.theta_star, a.theta_star))
    assert skipped_invalid_top >= 2  # the check above compared real θ* searches
    assert calls["first"] < calls["full"] / 4
    assert first_valid_only(None) is None
    backend.close()
