"""The paper benches' lazy validity test picks exactly the most confident control the full
test picks (GP and scikit-learn models, on the synthetic skill with an invalid corner)."""

from __future__ import annotations

import numpy as np
import pytest

from bench.paper.common import first_valid_lazy
from ltamp_cli.backends import load_backend
from ltamp_cli.learning.active import LearningConfig, learn_online


@pytest.mark.parametrize("strategy", ["gp", "rf-r"])
def test_lazy_validity_gives_the_same_most_confident_control(strategy: str) -> None:
    backend = load_backend("synthetic")
    calls = {"full": 0, "lazy": 0}

    def full(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        calls["full"] += len(controls)
        return backend.is_valid("skill8d", context, controls)

    def counted(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        calls["lazy"] += len(controls)
        return backend.is_valid("skill8d", context, controls)

    model = learn_online(backend, "skill8d",
                         LearningConfig(strategy=strategy, budget=20, seed=1)).model
    lazy = first_valid_lazy(counted)
    rng = np.random.default_rng(5)
    for index in range(5):
        context = backend.sample_context("skill8d", rng)
        a, _ = model.most_confident_control(context, np.random.default_rng(index), full, 2000)
        b, _ = model.most_confident_control(context, np.random.default_rng(index), lazy, 2000)
        np.testing.assert_allclose(a, b)
        assert backend.is_valid("skill8d", context, b[None, :])[0]
    assert calls["lazy"] < calls["full"] / 4
    backend.close()


def test_lazy_validity_reports_the_first_valid_ones() -> None:
    valid = np.array([False, False, True, False, True, True, True, False, True, True])
    lazy = first_valid_lazy(lambda context, controls: valid[controls[:, 0].astype(int)],
                            chunk=2, need=2)
    result = lazy(np.zeros(1), np.arange(10, dtype=float)[:, None])
    # Checked chunk by chunk until 2 valid ones were seen: [2, 3] holds one, [4, 5] two more.
    assert result.tolist() == [False, False, True, False, True, True, False, False, False,
                               False]
