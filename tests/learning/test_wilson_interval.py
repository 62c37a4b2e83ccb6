"""The one Wilson score interval every report and benchmark uses
(:func:`ltamp_cli.learning.metrics.wilson_interval`)."""

from __future__ import annotations

import pytest
from scipy.stats import binomtest

from ltamp_cli.learning.metrics import wilson_interval


@pytest.mark.parametrize(("k", "n"), [(0, 1), (1, 1), (0, 20), (3, 20), (17, 20), (20, 20),
                                      (191, 200), (359, 400), (7885, 10000)])
@pytest.mark.parametrize("confidence", [0.9, 0.95, 0.99])
def test_matches_scipy(k: int, n: int, confidence: float) -> None:
    ci = binomtest(k, n).proportion_ci(confidence_level=confidence, method="wilson")
    assert wilson_interval(k, n, confidence) == pytest.approx((ci.low, ci.high), abs=1e-12)


def test_known_values_and_edges() -> None:
    low, high = wilson_interval(10, 10)
    assert high == 1.0 and low == pytest.approx(0.7225, abs=1e-4)
    low, high = wilson_interval(5, 10)
    assert (low, high) == pytest.approx((0.2366, 0.7634), abs=1e-4)
    assert wilson_interval(0, 0) == (0.0, 1.0)  # no trials: nothing known
    # The engine rule's threshold (bench.paper.pools.engine_agrees): 197 of 200 is the least
    # count whose lower end reaches 0.95 (196 gives 0.9497), 389 of 400, 581 of 600.
    for least, n in ((197, 200), (389, 400), (581, 600)):
        assert wilson_interval(least, n)[0] >= 0.95 > wilson_interval(least - 1, n)[0]


@pytest.mark.parametrize(("k", "n", "confidence"), [(-1, 5, 0.95), (6, 5, 0.95), (1, 5, 1.0),
                                                    (1, 5, 0.0)])
def test_refuses_impossible_counts(k: int, n: int, confidence: float) -> None:
    with pytest.raises(ValueError):
        wilson_interval(k, n, confidence)
