"""PDDLStream's ``solve``: plan for a :class:`~.language.PDDLProblem` with ltamp's planner."""

from __future__ import annotations

import argparse
import math
from collections.abc import Mapping
from typing import Any

from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream.language import (
    WILD,
    Action,
    Certificate,
    PDDLProblem,
    PlanConstraints,
    Solution,
)
from ltamp_cli.pddlstream.problem import Info, to_planning_problem
from ltamp_cli.planner.algorithms.common import ALGORITHMS, PlannerConfig
from ltamp_cli.planner.api import solve as plan
from ltamp_cli.planner.objects import value_key as _value_key
from ltamp_cli.planner.pddl.check import check_domain, check_problem
from ltamp_cli.planner.pddl.parse import parse_domain, parse_problem
from ltamp_cli.planner.pddl.syntax import OBJECT_TYPE, Domain, IncreaseCost
from ltamp_cli.planner.problem import PlanningProblem
from ltamp_cli.planner.result import PlanResult
from ltamp_cli.planner.search.skeleton import ArgPattern, Skeleton, StepPattern
from ltamp_cli.planner.search.skeleton import PlanConstraints as SkeletonConstraints

FOCUSED_ALGORITHMS = ("focused", "binding", "adaptive")


# PDDLStream's other options of ``solve`` and of its search (``**search_kwargs``): accepted
# so that scripts run unchanged, without effect. They tune PDDLStream's own search (Fast
# Downward's ``planner`` and its time, effort weights, skeleton queue, deferral), or limit
# it (``max_iterations``, ``max_memory``): ltamp's planner has its own, and ``max_time``
# bounds it. Any other keyword is refused (a misspelt ``max_tme=`` would run unbounded).
IGNORED_OPTIONS = frozenset({
    "replan_actions", "max_iterations", "max_memory", "complexity_step", "max_skeletons",
    "search_sample_ratio", "max_failures", "unit_efforts", "max_effort", "effort_weight",
    "reorder", "visualize", "debug", "planner", "max_planner_time", "max_cost", "temp_dir",
    "clean", "hierarchy", "bind", "fail_fast", "subgoal_horizon"})


def solve(problem: PDDLProblem, algorithm: str = "adaptive",
          constraints: PlanConstraints | None = None,
          stream_info: Mapping[str, Info] | None = None, max_time: float = math.inf,
          unit_costs: bool = False, success_cost: float = math.inf, verbose: bool = True,
          seed: int = 0, search: str = "ff", initial_complexity: int = 0,
          max_complexity: float | None = None, **pddlstream_options: Any) -> Solution:
    """Solve like PDDLStream's ``solve`` and return ``Solution(plan, cost, certificate)``.

    ``algorithm``: ``adaptive`` (default), ``binding``, ``focused`` or ``incremental``;
    ``max_time`` in seconds (``inf``: until solved or proven infeasible); ``success_cost``:
    keep improving the plan until its cost is at most this. ``initial_complexity`` and
    ``max_complexity`` (integers >= 0; ``max_complexity=INF``: never give up before
    ``max_time``; ``None``: ltamp's default, 20) bound the stream complexity as in
    PDDLStream. Plan steps carry the Python values of their arguments. PDDLStream's other
    options (:data:`IGNORED_OPTIONS`: ``planner``, ``max_skeletons``, ``effort_weight``, ...)
    are accepted and have no effect; any other keyword is refused. Bad input raises
    :class:`~ltamp_cli.errors.InputError` (one line, ``file:line:col`` for PDDL).
    """
    unknown = sorted(set(pddlstream_options) - IGNORED_OPTIONS)
    if unknown:
        raise InputError(f"solve(): unknown option {unknown[0]!r} (neither ltamp's nor "
                         "PDDLStream's; see docs/porting-from-pddlstream.md)")
    if algorithm not in ALGORITHMS:
        raise InputError(f"unknown algorithm {algorithm!r}: expected one of "
                         f"{', '.join(ALGORITHMS)}")
    complexity = {"initial_complexity": _complexity("initial_complexity", initial_complexity)}
    if max_complexity is not None:
        complexity["max_complexity"] = _complexity("max_complexity", max_complexity,
                                                   infinite=True)
    planning_problem = to_planning_problem(problem, stream_info)
    skeletons = plan_constraints(constraints, planning_problem)
    max_cost = math.inf if constraints is None else constraints.max_cost
    config = PlannerConfig(algorithm=algorithm, max_time=max_time, seed=seed, search=search,
                           unit_costs=unit_costs, success_cost=success_cost,
                           constraints=skeletons, max_cost=max_cost, **complexity)
    result = plan(planning_problem, config)
    solution = to_solution(result, unit_costs or not has_action_costs(planning_problem.domain))
    if verbose:
        print(f"ltamp {algorithm}: {result.status} in {result.time_s:.3f} s"
              + (f", cost {solution.cost:g}" if result.solved else ""))
    return solution


def _complexity(option: str, value: Any, infinite: bool = False) -> Any:
    """A complexity bound: an integer >= 0 (``inf`` too when ``infinite``)."""
    if infinite and isinstance(value, float) and value == math.inf:
        return value
    if isinstance(value, float) and value.is_integer() and value >= 0:
        return int(value)
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise InputError(f"{option}: expected an integer >= 0"
                         + (" or INF" if infinite else "") + f", got {value!r:.40}")
    return value


def has_action_costs(domain: Domain) -> bool:
    """Whether any action increases ``total-cost`` (else, as in PDDLStream, each costs 1)."""
    def costs(effect: object) -> bool:
        if isinstance(effect, IncreaseCost):
            return True
        return any(costs(part) for part in getattr(effect, "parts", ())) or (
            hasattr(effect, "effect") and costs(effect.effect))
    return any(costs(action.effect) for action in domain.actions)


def solve_incremental(problem: PDDLProblem, **options: Any) -> Solution:
    return solve(problem, algorithm="incremental", **options)


def solve_focused(problem: PDDLProblem, **options: Any) -> Solution:
    return solve(problem, algorithm="focused", **options)


def solve_binding(problem: PDDLProblem, **options: Any) -> Solution:
    return solve(problem, algorithm="binding", **options)


def solve_adaptive(problem: PDDLProblem, **options: Any) -> Solution:
    return solve(problem, algorithm="adaptive", **options)


def plan_constraints(constraints: PlanConstraints | None, problem: PlanningProblem
                     ) -> SkeletonConstraints | None:
    """PDDLStream's skeletons as the planner's constraints (``None``: no skeleton). A value
    that is no object of the problem yet becomes one (added to ``problem.objects``), as in
    PDDLStream: a stream output equal to it is then that object."""
    if constraints is None:
        return None
    if not isinstance(constraints, PlanConstraints):
        raise InputError(f"constraints: expected PlanConstraints(skeletons=..., exact=..., "
                         f"max_cost=...), got {constraints!r:.60}")
    if constraints.skeletons is None:
        return None
    if not constraints.skeletons:
        raise InputError("PlanConstraints(skeletons=[]): no plan follows an empty list of "
                         "skeletons (skeletons=None plans freely)")
    by_value = {_value_key(value): name for name, (_, value) in problem.objects.items()
                if value is not None}
    by_value.update({_value_key(name): name for name, (_, value) in problem.objects.items()
                     if value is None})

    def object_name(value: Any) -> str:
        key = _value_key(value)
        if key not in by_value:
            name = f"skeleton-value-{len(by_value)}"
            while name in problem.objects:
                name += "-"
            problem.objects[name] = (OBJECT_TYPE, value)
            by_value[key] = name
        return by_value[key]

    groups = {_group_key(group): frozenset(object_name(v) for v in values)
              for group, values in constraints.groups.items()}

    def arg_pattern(arg: Any) -> ArgPattern:
        if isinstance(arg, str) and arg == WILD:
            return None
        if isinstance(arg, str) and arg.startswith("?"):
            return arg.lower()
        group = _group_key(arg)
        if group is not None and group in groups:
            return groups[group]
        return frozenset({object_name(arg)})

    skeletons = []
    for number, skeleton in enumerate(constraints.skeletons, start=1):
        steps = []
        for step in skeleton.actions:
            if not (isinstance(step, tuple | list) and len(step) == 2
                    and isinstance(step[0], str) and isinstance(step[1], tuple | list)):
                raise InputError(f"skeleton #{number}: step {step!r:.60} is no (action name, "
                                 "[args]) pair")
            name, args = step
            steps.append(StepPattern(name.lower(), tuple(arg_pattern(a) for a in args)))
        try:
            orders = frozenset((int(i), int(j)) for i, j in skeleton.orders)
        except (TypeError, ValueError):
            raise InputError(f"skeleton #{number}: orders must be pairs of step indices "
                             f"(GOAL_INDEX for the end), got {skeleton.orders!r:.60}") from None
        skeletons.append(Skeleton(tuple(steps), orders, (not constraints.exact,)
                                  * (len(steps) + 1)))
    return SkeletonConstraints(tuple(skeletons))


def _group_key(value: Any) -> Any:
    """``value`` as a key of ``PlanConstraints.groups`` (``None`` if unhashable: PDDLStream
    looks up only hashable args)."""
    try:
        hash(value)
    except TypeError:
        return None
    return value


def solve_from_pddl(domain_pddl: str, problem_pddl: str, unit_costs: bool = False,
                    max_time: float = math.inf, **pddlstream_options: Any
                    ) -> tuple[list[Action] | None, float]:
    """Plan for a PDDL domain and problem (no streams): ``(plan, cost)`` as PDDLStream's
    ``solve_from_pddl``; arguments are object names. PDDLStream's search options
    (:data:`IGNORED_OPTIONS`) have no effect; any other keyword is refused."""
    unknown = sorted(set(pddlstream_options) - IGNORED_OPTIONS)
    if unknown:
        raise InputError(f"solve_from_pddl(): unknown option {unknown[0]!r}")
    domain = parse_domain(domain_pddl, getattr(domain_pddl, "path", "domain.pddl"))
    check_domain(domain)
    parsed = parse_problem(problem_pddl, getattr(problem_pddl, "path", "problem.pddl"))
    check_problem(parsed, domain)
    objects = {o.name: (o.type, None) for o in parsed.objects}
    for constant in domain.constants:
        objects.setdefault(constant.name, (constant.type, None))
    problem = PlanningProblem(parsed.name, getattr(problem_pddl, "path", "problem.pddl"), domain,
                              None, None, "", {}, objects, parsed.init,
                              parsed.function_values, parsed.goal)
    result = plan(problem, PlannerConfig(max_time=max_time, unit_costs=unit_costs))
    if not result.solved or result.plan is None:
        return None, math.inf
    cost = (float(len(result.plan)) if unit_costs or not has_action_costs(domain)
            else result.cost)
    return [Action(step.name, step.args) for step in result.plan], cost


def get_cost_scale() -> float:
    """PDDLStream scales costs to integers for Fast Downward; ltamp plans with the costs as
    they are, so the scale is 1."""
    return 1.0


def create_parser(default_algorithm: str = "adaptive") -> argparse.ArgumentParser:
    """PDDLStream's command-line parser: ``-a/--algorithm`` and ``-u/--unit``."""
    parser = argparse.ArgumentParser()
    parser.add_argument("-a", "--algorithm", default=default_algorithm, choices=ALGORITHMS,
                        help="the planning algorithm")
    parser.add_argument("-u", "--unit", action="store_true", help="use unit action costs")
    return parser


def to_solution(result: PlanResult, unit_costs: bool = False) -> Solution:
    """The planner's result with every object replaced by its Python value (``unit_costs``:
    the cost is the number of actions)."""
    def value(name: str) -> Any:
        return result.objects.get(name, name)

    def fact(names: tuple[str, ...]) -> tuple[Any, ...]:
        return (names[0], *(value(n) for n in names[1:]))

    certificate = Certificate([fact(f) for f in result.certificate.facts],
                              [fact(f) for f in result.certificate.preimage])
    if result.plan is None or not result.solved:
        return Solution(None, math.inf, certificate)
    plan_steps = [Action(step.name, tuple(step.values)) for step in result.plan]
    return Solution(plan_steps, float(len(plan_steps)) if unit_costs else result.cost,
                    certificate)
