"""Report cells: mean ± std over seeds (std from ``summarize``'s standard error), the plain mean
for a single run, and the few-positives warning with its scoop explanation."""

from __future__ import annotations

import math

from bench.paper.report import _curve_table, _few_positives
from ltamp_cli.learning.curves import summarize


def test_curve_cells_are_mean_pm_std_over_seeds() -> None:
    rows = [{"learner": "gp", "n_trials": 10, "f1": 0.2}, {"learner": "gp", "n_trials": 10,
                                                            "f1": 0.6},
            {"learner": "nn-c", "n_trials": 10, "f1": 0.4}]
    table = _curve_table(summarize(rows), ["gp", "nn-c"], {"gp": "GP"}, "f1")
    std = math.sqrt(((0.2 - 0.4) ** 2 + (0.6 - 0.4) ** 2) / 1)  # sample std (ddof = 1)
    assert table[2] == f"| GP | 0.40 ± {std:.2f} |"
    assert table[3] == "| nn-c | 0.40 |"  # one run: no spread to show


def test_few_positives_warns_and_explains_only_the_pybullet_scoop() -> None:
    pool = {"test_positives": 2, "positive_fraction": 0.1, "n_test": 30}
    assert "Only 2 test positives" in _few_positives(pool)
    assert "Why so few" in _few_positives(pool, "scoop", "pybullet")
    assert "Why so few" not in _few_positives(pool, "pour", "pybullet")
    assert _few_positives({**pool, "test_positives": 5}, "scoop", "pybullet") == ""
