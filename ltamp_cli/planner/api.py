"""The planner's entry point: :func:`solve`."""

from __future__ import annotations

from collections.abc import Callable

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

COST_EPSILON = 1e-6


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
    if config.algorithm not in ALGORITHMS:
        raise InputError(f"unknown algorithm {config.algorithm!r}: expected one of "
                         f"{', '.join(ALGORITHMS)}")
    if config.search not in SEARCH_ALGORITHMS:
        raise InputError(f"unknown search {config.search!r}: expected one of "
                         f"{', '.join(SEARCH_ALGORITHMS)}")
    if config.max_time <= 0:
        raise InputError(f"max time must be positive, got {config.max_time}")
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
