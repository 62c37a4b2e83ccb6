"""bench.paper.stats.sign_flip_test: the exact paired permutation test over sign patterns."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from bench.paper.stats import SIGN_FLIP_EXACT_MAX, sign_flip_test, sign_test


def _by_enumeration(values: list[float]) -> float:
    observed = abs(np.mean(values))
    hits = [abs(np.mean(np.multiply(signs, values))) >= observed - 1e-12
            for signs in itertools.product((1, -1), repeat=len(values))]
    return float(np.mean(hits))


def test_all_positive_units_give_two_patterns_of_the_observed_size() -> None:
    assert sign_flip_test(np.ones(5)) == pytest.approx(2 / 32)
    assert sign_flip_test(np.array([1.0, -1.0])) == 1.0
    assert sign_flip_test(np.zeros(4)) == 1.0


@pytest.mark.parametrize("seed", range(5))
def test_it_is_the_share_of_sign_patterns_at_least_as_extreme(seed: int) -> None:
    values = np.random.default_rng(seed).normal(0.1, 0.3, size=8).round(2).tolist()
    assert sign_flip_test(np.array(values)) == pytest.approx(_by_enumeration(values))


def test_sizes_matter_where_the_sign_test_sees_only_signs() -> None:
    # Eight large wins and two small losses: the sign test cannot reject, this one can.
    values = np.array([0.44, -0.02, 0.30, 0.20, -0.06, 0.32, 0.12, 0.26, 0.24, 0.50])
    assert sign_test(values)[0] > 0.1
    assert sign_flip_test(values) < 0.01
    with pytest.raises(ValueError, match="exact up to"):
        sign_flip_test(np.ones(SIGN_FLIP_EXACT_MAX + 1))
