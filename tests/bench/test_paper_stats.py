"""Paired claims (bootstrap interval + exact sign test) and resumable experiment jobs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bench.paper.common import Context, JobLog
from bench.paper.report import _paired_units, _short_limit_claim
from bench.paper.stats import MIN_UNITS, best_of, bootstrap_interval, paired_comparison


def test_a_clearly_better_holds_and_reversed_does_not() -> None:
    rng = np.random.default_rng(0)
    b = rng.random(60)
    a = b + 0.2 + 0.05 * rng.standard_normal(60)
    better = paired_comparison("A", a, "B", b)
    assert better.verdict == "holds"
    assert 0.17 < better.low < better.difference < better.high < 0.23
    assert better.p_value < 1e-6 and better.wins > 55
    assert paired_comparison("B", b, "A", a).verdict == "does not hold"


def test_one_or_few_units_are_inconclusive_even_with_a_zero_width_interval() -> None:
    single = paired_comparison("A", [1.0], "B", [0.0])
    assert (single.low, single.high) == (1.0, 1.0)  # the bootstrap alone would say "holds"
    assert single.verdict == "inconclusive"
    assert paired_comparison("A", [1, 1, 1], "B", [0, 0, 0]).verdict == "inconclusive"
    # Six wins out of six: the exact sign test reaches p = 1/32 < 0.05.
    assert paired_comparison("A", [1] * 6, "B", [0] * 6).verdict == "holds"


def test_noise_alone_is_inconclusive() -> None:
    rng = np.random.default_rng(1)
    a, b = rng.integers(0, 2, 40), rng.integers(0, 2, 40)
    assert paired_comparison("A", a, "B", b).verdict == "inconclusive"


def test_a_negligible_improvement_does_not_hold_given_a_margin_and_enough_units() -> None:
    rng = np.random.default_rng(2)
    b = rng.random(400)
    a = b + 0.01 + 0.01 * rng.standard_normal(400)
    assert paired_comparison("A", a, "B", b).verdict == "holds"  # real, but tiny
    assert paired_comparison("A", a, "B", b, margin=0.05).verdict == "holds"
    tied = paired_comparison("A", b, "B", b, margin=0.05)
    assert tied.verdict == "does not hold" and tied.n >= MIN_UNITS
    assert paired_comparison("A", b[:5], "B", b[:5], margin=0.05).verdict == "inconclusive"


def test_best_of_needs_every_pairwise_claim_at_a_bonferroni_level() -> None:
    rng = np.random.default_rng(3)
    base = rng.random(80)
    scores = {"best": base + 0.3, "mid": base + 0.15, "low": base}
    claim = best_of("best wins", "best", scores)
    assert claim.verdict == "holds"
    assert all(c.confidence == pytest.approx(0.975) for c in claim.comparisons)
    assert best_of("mid wins", "mid", scores).verdict == "does not hold"
    assert best_of("nobody", "absent", scores).verdict == "inconclusive"


def test_bootstrap_interval_covers_the_mean_at_the_nominal_rate() -> None:
    rng = np.random.default_rng(4)
    covered = 0
    for trial in range(200):
        sample = rng.standard_normal(40) + 1.0
        low, high = bootstrap_interval(sample, 0.9, n_boot=1000, seed=trial)
        covered += low <= 1.0 <= high
    assert 0.8 <= covered / 200 <= 0.97  # nominal 0.9; binomial sd ~0.02


def test_paired_units_expand_per_context_successes_over_shared_seeds() -> None:
    runs = [{"learner": "a", "seed": 0, "n_trials": 10, "success_rate": 0.5,
             "successes": [True, False]},
            {"learner": "a", "seed": 1, "n_trials": 10, "success_rate": 1.0,
             "successes": [True, True]},
            {"learner": "b", "seed": 0, "n_trials": 10, "success_rate": 0.0,
             "successes": [False, False]},
            {"learner": "a", "seed": 0, "n_trials": 20, "success_rate": 1.0,
             "successes": [True, True]}]
    units = _paired_units(runs, ["a", "b"], "success_rate")
    # Checkpoint 10 is the last both measured; seed 1 has no "b" run to pair with.
    assert units["a"].tolist() == [1.0, 0.0] and units["b"].tolist() == [0.0, 0.0]
    no_contexts = [{k: v for k, v in r.items() if k != "successes"} for r in runs]
    assert _paired_units(no_contexts, ["a", "b"], "success_rate")["a"].tolist() == [0.5]


def test_short_limit_claim_pairs_planner_seeds_and_judges_cpu_time() -> None:
    def detail(solved_cpu: list[float | None]) -> dict[str, object]:
        return {"detail": [{"seed": s, "status": "timeout" if c is None else "solved",
                            "cpu_s": c} for s, c in enumerate(solved_cpu)]}

    row = {"task": "T", "short_s": 1.0,
           "samplers": {"diverse-lk": detail([0.5] * 8), "adaptive": detail([2.0] * 8),
                        "diverse": detail([None] * 8)}}
    claim = _short_limit_claim(row)
    assert claim.verdict == "holds"
    assert [c.n for c in claim.comparisons] == [8, 8]


def test_job_log_resumes_finished_jobs_and_ignores_torn_lines(tmp_path: Path) -> None:
    ctx = Context("quick", tmp_path, False)
    calls: list[str] = []

    def job(name: str) -> list[dict[str, object]]:
        calls.append(name)
        return [{"value": np.float64(len(name)), "successes": (True, False)}]

    log = JobLog(ctx, "exp", {"seeds": 2})
    first = log.run("a", lambda: job("a"))
    assert first == [{"value": 1.0, "successes": [True, False]}]
    with log.path.open("a") as handle:
        handle.write('{"key": "b", "sizes": "x", "ro')  # an interrupted write
    again = JobLog(ctx, "exp", {"seeds": 2})
    assert again.run("a", lambda: job("a")) == first and calls == ["a"]
    again.run("bb", lambda: job("bb"))
    assert calls == ["a", "bb"]
    assert JobLog(ctx, "exp", {"seeds": 2}).get("bb") == [{"value": 2.0,
                                                           "successes": [True, False]}]
    # Other sizes: the earlier jobs do not count.
    other = JobLog(ctx, "exp", {"seeds": 3})
    assert other.get("a") is None
