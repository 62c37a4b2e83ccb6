"""Stream effort estimates and the effort order of stream plans."""

from __future__ import annotations

import json

import pytest

from ltamp_cli.planner.algorithms.effort import Effort, estimate_effort, order_by_effort
from ltamp_cli.planner.streams import StreamInfo, StreamStats


def test_prior_alone_gives_the_binding_hints() -> None:
    effort = estimate_effort(StreamInfo(p_success=0.25, overhead=3.0), None, None)
    assert effort.p_success == pytest.approx(0.25)
    assert effort.overhead_s == pytest.approx(3.0)


def test_history_and_run_outweigh_the_prior() -> None:
    history = {"calls": 98.0, "successes": 49.0, "time_s": 0.98}
    run = StreamStats(calls=100, successes=50, outputs=50, time_s=1.0)
    effort = estimate_effort(StreamInfo(), history, run)
    # 2 prior calls (p = 1, 1 s each) + 198 observed calls (p = 0.5); the overhead comes from
    # the prior and the persisted history only (98 calls of 0.01 s).
    assert effort.p_success == pytest.approx((2 + 99) / 200)
    assert effort.overhead_s == pytest.approx((2 + 0.98) / 100)


def test_run_timing_does_not_change_the_effort() -> None:
    # Measured seconds of the current run are noise-dependent: they must not reorder stream
    # plans (determinism per seed), while its successes and failures do count.
    fast = StreamStats(calls=10, successes=2, outputs=2, time_s=1e-5)
    slow = StreamStats(calls=10, successes=2, outputs=2, time_s=3.0)
    assert estimate_effort(StreamInfo(), None, fast) == estimate_effort(StreamInfo(), None, slow)
    assert estimate_effort(StreamInfo(), None, fast).p_success == pytest.approx(4 / 12)


def test_cheap_likely_failures_go_first_but_never_before_their_inputs() -> None:
    sample = ("sample", ("a",))
    slow_test = ("slow-test", ("a",))
    cheap_test = ("cheap-test", ("#p0",))
    reliable = ("reliable", ("b",))
    effort = {
        "sample": Effort(0.9, 1.0),
        "slow-test": Effort(0.5, 10.0),
        "cheap-test": Effort(0.5, 0.01),
        "reliable": Effort(1.0, 0.015),
    }
    dependencies = {cheap_test: {sample}}
    order = order_by_effort([reliable, slow_test, sample, cheap_test], dependencies, effort)
    assert order.index(sample) < order.index(cheap_test)
    # Keys: sample 1 / 0.1 = 10, reliable 0.015 / 1e-3 = 15, slow-test 10 / 0.5 = 20; the
    # cheap test (0.02) runs as soon as its input exists.
    assert order == [sample, cheap_test, reliable, slow_test]


def test_equal_efforts_keep_the_given_order() -> None:
    keys = [("s", (str(i),)) for i in range(5)]
    assert order_by_effort(keys, {}, {"s": Effort(1.0, 1.0)}) == keys


def test_planner_state_blends_persisted_history(tmp_path) -> None:
    from pathlib import Path

    from ltamp_cli.planner.algorithms.common import PlannerConfig, initial_state
    from ltamp_cli.planner.problem import load_problem

    repo = Path(__file__).resolve().parents[2]
    problem = load_problem(repo / "problems" / "examples" / "tamp2d_blocked.yaml")
    state = initial_state(problem, PlannerConfig(seed=0))
    fresh = state.effort("test-cfree")
    state.history = {"test-cfree": {"calls": 1000.0, "successes": 100.0, "time_s": 0.5}}
    informed = state.effort("test-cfree")
    assert informed.p_success < 0.15 < fresh.p_success
    assert informed.order_key < fresh.order_key


def test_statistics_make_cheap_samplers_eager_when_asked(tmp_path) -> None:
    """The symbolic kitchen's slot sampler is cheap: once statistics show it, evaluating it
    eagerly lets the first optimistic search find a plan (without the option, the plan
    places objects on placeholder slots that later collide, and iterates)."""
    from pathlib import Path

    from ltamp_cli.planner.algorithms.common import PlannerConfig
    from ltamp_cli.planner.api import solve
    from ltamp_cli.planner.problem import load_problem

    repo = Path(__file__).resolve().parents[2]
    problem = load_problem(repo / "problems" / "examples" / "kitchen_symbolic.yaml")
    history = str(tmp_path / "statistics")
    warm_up = solve(problem, PlannerConfig(seed=7, max_time=60, statistics_dir=history))
    assert warm_up.solved
    plain = solve(problem, PlannerConfig(seed=0, max_time=60, statistics_dir=history))
    eager = solve(problem, PlannerConfig(seed=0, max_time=60, statistics_dir=history,
                                         eager_cheap_streams=True))
    assert plain.solved and eager.solved
    assert eager.stats["iterations"] == 1 < plain.stats["iterations"]


def test_cheap_decision_uses_cpu_time_persisted_in_the_history(tmp_path) -> None:
    """A 20 us sampler preempted on a loaded machine measures milliseconds of wall time; the
    persisted CPU time decides, and histories without it fall back to their wall time."""
    from ltamp_cli.planner.algorithms.effort import observed_cheap
    from ltamp_cli.planner.statistics import StreamStatistics, statistics_file_name

    older_file = {"version": 1, "streams": {"slot": {"calls": 4, "successes": 4, "time_s": 0.02}}}
    (tmp_path / statistics_file_name("toy")).write_text(json.dumps(older_file))
    statistics = StreamStatistics.load(tmp_path, "toy")
    statistics.update({"slot": StreamStats(calls=2, successes=2, outputs=2, time_s=0.01,
                                           cpu_s=4e-5)})
    statistics.save()
    totals = StreamStatistics.load(tmp_path, "toy").totals["slot"]
    assert totals["calls"] == 6 and totals["cpu_s"] == pytest.approx(0.02 + 4e-5)
    assert not observed_cheap(totals, None)  # the old calls' wall time still counts
    loaded_machine = {"calls": 6, "successes": 6, "time_s": 0.03, "cpu_s": 1.2e-4}
    assert observed_cheap(loaded_machine, None)
    assert not observed_cheap({"calls": 6, "time_s": 0.03}, None)


def test_cold_run_probes_unmeasured_streams_before_the_first_search() -> None:
    """Without any history, ``eager_cheap_streams`` calls each unmeasured stream once before
    the first search, so its cheap samplers are eager from the start: kitchen_symbolic then
    plans with one search (as a warm run does) instead of the optimistic searches a cold run
    made before; without the option nothing is probed."""
    from pathlib import Path

    from ltamp_cli.planner.algorithms.common import PlannerConfig, initial_state
    from ltamp_cli.planner.algorithms.optimistic import probe_unmeasured
    from ltamp_cli.planner.api import solve
    from ltamp_cli.planner.problem import load_problem

    repo = Path(__file__).resolve().parents[2]
    problem = load_problem(repo / "problems" / "examples" / "kitchen_symbolic.yaml")
    state = initial_state(problem, PlannerConfig(seed=0, eager_cheap_streams=True))
    probe_unmeasured(state)
    probed = {name for name, stats in state.stream_stats.items() if stats.calls}
    # Every non-eager stream without :fluents whose inputs are real initially, once each.
    assert probed and all(state.stream_stats[name].calls == 1 for name in probed)
    assert not any(state.bindings[name].info.eager for name in probed)
    probe_unmeasured(state)  # measured now: not called again
    assert all(state.stream_stats[name].calls == 1 for name in probed)

    eager = solve(problem, PlannerConfig(seed=0, max_time=60, eager_cheap_streams=True))
    plain = solve(problem, PlannerConfig(seed=0, max_time=60))
    assert eager.solved and plain.solved
    assert eager.stats["searches"] == 1 < plain.stats["searches"]
