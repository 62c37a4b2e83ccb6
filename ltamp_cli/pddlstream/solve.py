"""PDDLStream's ``solve``: plan for a :class:`~.language.PDDLProblem` with ltamp's planner."""

from __future__ import annotations

import argparse
import math
from collections.abc import Mapping
from typing import Any

from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream.language import Action, Certificate, PDDLProblem, Solution
from ltamp_cli.pddlstream.problem import Info, to_planning_problem
from ltamp_cli.planner.algorithms.common import ALGORITHMS, PlannerConfig
from ltamp_cli.planner.api import solve as plan
from ltamp_cli.planner.result import PlanResult


def solve(problem: PDDLProblem, algorithm: str = "adaptive",
          stream_info: Mapping[str, Info] | None = None, max_time: float = math.inf,
          unit_costs: bool = False, success_cost: float = math.inf, verbose: bool = True,
          seed: int = 0, search: str = "ff", **ignored: Any) -> Solution:
    """Solve like PDDLStream's ``solve`` and return ``Solution(plan, cost, certificate)``.

    ``algorithm``: ``adaptive`` (default), ``binding``, ``focused`` or ``incremental``;
    ``max_time`` in seconds (``inf``: until solved or proven infeasible); ``success_cost``:
    keep improving the plan until its cost is at most this. Plan steps carry the Python
    values of their arguments. PDDLStream's other options (``planner``, ``max_skeletons``,
    ``effort_weight``, ...) are accepted and ignored. Bad input raises
    :class:`~ltamp_cli.errors.InputError` (one line, ``file:line:col`` for PDDL).
    """
    if algorithm not in ALGORITHMS:
        raise InputError(f"unknown algorithm {algorithm!r}: expected one of "
                         f"{', '.join(ALGORITHMS)}")
    planning_problem = to_planning_problem(problem, stream_info)
    config = PlannerConfig(algorithm=algorithm, max_time=max_time, seed=seed, search=search,
                           unit_costs=unit_costs, success_cost=success_cost)
    result = plan(planning_problem, config)
    if verbose:
        print(f"ltamp {algorithm}: {result.status} in {result.time_s:.3f} s"
              + (f", cost {result.cost:g}" if result.solved else ""))
    return to_solution(result)


def create_parser(default_algorithm: str = "adaptive") -> argparse.ArgumentParser:
    """PDDLStream's command-line parser: ``-a/--algorithm`` and ``-u/--unit``."""
    parser = argparse.ArgumentParser()
    parser.add_argument("-a", "--algorithm", default=default_algorithm, choices=ALGORITHMS,
                        help="the planning algorithm")
    parser.add_argument("-u", "--unit", action="store_true", help="use unit action costs")
    return parser


def to_solution(result: PlanResult) -> Solution:
    """The planner's result with every object replaced by its Python value."""
    def value(name: str) -> Any:
        return result.objects.get(name, name)

    def fact(names: tuple[str, ...]) -> tuple[Any, ...]:
        return (names[0], *(value(n) for n in names[1:]))

    certificate = Certificate([fact(f) for f in result.certificate.facts],
                              [fact(f) for f in result.certificate.preimage])
    if result.plan is None or not result.solved:
        return Solution(None, math.inf, certificate)
    plan_steps = [Action(step.name, tuple(step.values)) for step in result.plan]
    return Solution(plan_steps, result.cost, certificate)
