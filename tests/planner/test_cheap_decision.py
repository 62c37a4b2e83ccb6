"""The planner's "observed cheap" decision (``effort.observed_cheap``: cheap streams are
evaluated eagerly, repaired and probed locally) made deterministic (issue #19): decided once
per stream and solve, from the persisted history when there is one, against 1 ms of mean CPU
per call. On main it was remade at every use against 250 us, so a stream whose calls
measured about that much (tamp2d_4blocks' sample-pose: 170-250 us on its first call) was
cheap in one run and not in the next, or became cheap in the middle of a solve: the same
seed gave different plans."""

from __future__ import annotations

import random
from collections.abc import Callable
from pathlib import Path

import pytest

from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.algorithms.effort import observed_cheap
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.result import PlanResult
from ltamp_cli.planner.streams import StreamStats

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"


def test_the_decision_is_kept_for_the_solve() -> None:
    """Made at the first call, then kept whatever later calls measure (main: remade at
    every use from the running mean)."""
    cheap = StreamStats(calls=1, cpu_s=100e-6)
    assert observed_cheap(None, cheap)
    cheap.calls, cheap.cpu_s = 10, 10 * 5e-3  # later calls measure 5 ms each
    assert observed_cheap(None, cheap)
    costly = StreamStats(calls=1, cpu_s=2e-3)
    assert not observed_cheap(None, costly)
    costly.calls, costly.cpu_s = 50, 2e-3 + 49 * 10e-6
    assert not observed_cheap(None, costly)
    assert not observed_cheap(None, StreamStats())  # no call: undecided, not cheap
    assert not observed_cheap(None, None)


def test_the_history_decides_alone_when_there_is_one() -> None:
    """The persisted history (a fixed input of the solve) decides; this run's noisy
    calls do not move it (main: their mean with the history's)."""
    history = {"calls": 10, "successes": 10, "time_s": 1e-4, "cpu_s": 1e-4}  # 10 us a call
    slow_first_call = StreamStats(calls=1, cpu_s=5e-3)
    assert observed_cheap(history, slow_first_call)
    costly_history = {"calls": 10, "successes": 10, "time_s": 0.03, "cpu_s": 0.02}
    assert not observed_cheap(costly_history, StreamStats(calls=1, cpu_s=1e-5))
    assert observed_cheap(history, None) and not observed_cheap(costly_history, None)


def test_a_millisecond_is_costly_and_less_is_cheap() -> None:
    """1 ms a call is costly even as a clock's float steps read it (0.999999... ms);
    between 250 us and 1 ms (main's threshold and the new one) is cheap."""
    ticks = [n * 1e-3 for n in range(8)]
    measured = sum(b - a for a, b in zip(ticks[2::2], ticks[3::2], strict=False))
    assert not observed_cheap(None, StreamStats(calls=3, cpu_s=measured))
    assert observed_cheap(None, StreamStats(calls=3, cpu_s=3 * 300e-6))
    assert observed_cheap(None, StreamStats(calls=3, cpu_s=3 * 999e-6))


class StepClock:
    """A CPU clock that advances at every reading by ``step()`` seconds: a timed stream
    call (two readings) measures the step of its second reading."""

    def __init__(self, step: Callable[[], float]) -> None:
        self.step, self.now = step, 0.0

    def __call__(self) -> float:
        self.now += self.step()
        return self.now


def jitter(seed: int) -> Callable[[], float]:
    """200 or 300 us at random: calls measured around main's 250 us threshold."""
    rng = random.Random(seed)
    return lambda: rng.choice((200e-6, 300e-6))


def solve_4blocks(step: Callable[[], float]) -> PlanResult:
    problem = load_problem(EXAMPLES / "tamp2d_4blocks.yaml")
    return solve(problem, PlannerConfig(algorithm="adaptive", seed=1, max_time=60,
                                        stream_cpu_clock=StepClock(step)))


def test_calls_measured_either_side_of_250_us_give_one_plan() -> None:
    """tamp2d_4blocks seed 1 (the example whose plan changed between runs on main) with
    every call measuring 200 us, 300 us, or either at random (two draws): one plan, values
    included, the same work and the same streams decided cheap. On main, 300 us made no
    stream cheap (its collision test was then left optimistic: other searches)."""
    runs = [solve_4blocks(lambda: 200e-6), solve_4blocks(lambda: 300e-6),
            solve_4blocks(jitter(0)), solve_4blocks(jitter(1))]
    first = runs[0]
    assert first.solved and "test-cfree" in first.stats["cheap_streams"]
    for run in runs[1:]:
        assert run.solved
        assert [(s.name, repr(s.values)) for s in run.plan] == [
            (s.name, repr(s.values)) for s in first.plan]
        assert run.stats["work"] == first.stats["work"]
        assert run.stats["cheap_streams"] == first.stats["cheap_streams"]


@pytest.mark.parametrize("seconds", [2e-3, 20e-3])
def test_calls_over_a_millisecond_are_not_cheap(seconds: float) -> None:
    result = solve_4blocks(lambda: seconds)
    assert result.solved and result.stats["cheap_streams"] == []
