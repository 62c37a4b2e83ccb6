"""The planner's entry point: :func:`solve`."""

from __future__ import annotations

import gc
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import replace

from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import (
    ALGORITHMS,
    PlannerConfig,
    PlannerState,
    initial_state,
)
from ltamp_cli.planner.algorithms.focused import solve_focused
from ltamp_cli.planner.algorithms.incremental import solve_incremental
from ltamp_cli.planner.algorithms.skeletons import solve_with_skeletons
from ltamp_cli.planner.problem import PlanningProblem
from ltamp_cli.planner.result import PlanResult
from ltamp_cli.planner.search.engine import SEARCH_ALGORITHMS
from ltamp_cli.planner.statistics import StreamStatistics
from ltamp_cli.seeds import usable_seed

COST_EPSILON = 1e-6
# Generation-0 threshold while a solve runs (CPython's default is 700). Search and grounding
# allocate many short-lived tuples, sets and dicts that reference counting frees anyway; at
# the default threshold the collector ran often enough to cost ~5-10 % of the CPU time of
# kitchen_symbolic and tamp2d_4blocks. Not disabled outright: a long solve with learned
# samplers could otherwise accumulate cyclic garbage without bound.
SOLVE_GC_THRESHOLD0 = 50_000


class _GcRelaxation:
    """Collect garbage less often while at least one solve runs.

    The collector's settings are process-wide, so they are changed only while a solve is in
    progress and restored when the last concurrent one ends (also on exceptions): the lock and
    the depth count mirror that interpreter-wide state and hold no planner data, so planners
    in different threads still do not interfere. (``gc.freeze`` of the caller's objects was
    tried too: unfreezing them at the end triggered a full collection costing ~40 ms.)
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._depth = 0
        self._saved: tuple[int, ...] = gc.get_threshold()

    @contextmanager
    def __call__(self) -> Iterator[None]:
        with self._lock:
            if self._depth == 0:
                self._saved = gc.get_threshold()
                gc.set_threshold(SOLVE_GC_THRESHOLD0, *self._saved[1:])
            self._depth += 1
        try:
            yield
        finally:
            with self._lock:
                self._depth -= 1
                if self._depth == 0:
                    gc.set_threshold(*self._saved)


_relaxed_gc = _GcRelaxation()


def _algorithm(name: str) -> Callable[[PlannerState], PlanResult]:
    if name == "incremental":
        return solve_incremental
    if name == "focused":
        return solve_focused
    return lambda state: solve_with_skeletons(state, adaptive=name == "adaptive")


def solve(problem: PlanningProblem, config: PlannerConfig | None = None) -> PlanResult:
    """Plan for ``problem``. Deterministic for a given ``config.seed``.

    With a finite ``config.success_cost`` the planner keeps looking for cheaper plans, reusing
    every sample, until one costs at most that or time runs out (anytime mode); the best plan
    found is returned with the cost of each improvement in ``stats["anytime_costs"]``.
    """
    config = config or PlannerConfig()
    if isinstance(config.seed, bool) or not isinstance(config.seed, int):
        raise InputError(f"seed must be an integer, got {config.seed!r}")
    config = replace(config, seed=usable_seed(config.seed))
    if config.algorithm not in ALGORITHMS:
        raise InputError(f"unknown algorithm {config.algorithm!r}: expected one of "
                         f"{', '.join(ALGORITHMS)}")
    if config.search not in SEARCH_ALGORITHMS:
        raise InputError(f"unknown search {config.search!r}: expected one of "
                         f"{', '.join(SEARCH_ALGORITHMS)}")
    if not config.max_time > 0:  # also NaN
        raise InputError(f"max time must be positive, got {config.max_time}")
    with _relaxed_gc():
        return _solve(problem, config)


def _solve(problem: PlanningProblem, config: PlannerConfig) -> PlanResult:
    statistics = StreamStatistics.load(config.statistics_dir, problem.domain.name)
    state = initial_state(problem, config)
    state.history = statistics.totals
    run = _algorithm(config.algorithm)
    best = run(state)
    improvements = [best.cost] if best.solved else []
    while (best.solved and best.cost > config.success_cost + COST_EPSILON
           and not state.timed_out()):
        state.cost_bound = best.cost
        better = run(state)
        if not better.solved or better.cost >= best.cost - COST_EPSILON:
            break
        best = better
        improvements.append(best.cost)
    if improvements:
        best.stats["anytime_costs"] = improvements
    statistics.update(state.stream_stats)
    statistics.save()
    best.stats["stream_history"] = statistics.summary()
    return best
