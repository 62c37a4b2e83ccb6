"""The planner's entry point: :func:`solve`."""

from __future__ import annotations

from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import ALGORITHMS, PlannerConfig, initial_state
from ltamp_cli.planner.algorithms.focused import solve_focused
from ltamp_cli.planner.algorithms.incremental import solve_incremental
from ltamp_cli.planner.algorithms.skeletons import solve_with_skeletons
from ltamp_cli.planner.problem import PlanningProblem
from ltamp_cli.planner.result import PlanResult
from ltamp_cli.planner.search.engine import SEARCH_ALGORITHMS


def solve(problem: PlanningProblem, config: PlannerConfig | None = None) -> PlanResult:
    """Plan for ``problem``. Deterministic for a given ``config.seed``."""
    config = config or PlannerConfig()
    if config.algorithm not in ALGORITHMS:
        raise InputError(f"unknown algorithm {config.algorithm!r}: expected one of "
                         f"{', '.join(ALGORITHMS)}")
    if config.search not in SEARCH_ALGORITHMS:
        raise InputError(f"unknown search {config.search!r}: expected one of "
                         f"{', '.join(SEARCH_ALGORITHMS)}")
    if config.max_time <= 0:
        raise InputError(f"max time must be positive, got {config.max_time}")
    state = initial_state(problem, config)
    if config.algorithm == "incremental":
        return solve_incremental(state)
    if config.algorithm == "focused":
        return solve_focused(state)
    return solve_with_skeletons(state, adaptive=config.algorithm == "adaptive")
