"""PDDLStream's constraint satisfaction: find values for free parameters that satisfy a set of
stream-certified facts, optionally minimising stream-defined functions.

A :class:`SatisfactionProblem` has no domain and no goal: ``terms`` are facts whose arguments
are Python values or ``?parameters``, and ``("minimize", (function, ...))`` objectives. It is
solved by compiling it to a one-action planning problem, as PDDLStream's planning-based
satisfaction does: the action's parameters are the free parameters, its precondition the
facts, its cost the minimised functions and its effect the goal. Values that appear in the
terms (``CONF0``, ``"A"``) are bound through one fresh initial fact each, so any Python value
works. The planner's streams then produce the bindings; the one plan step carries them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, NamedTuple

from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream.language import Certificate, PDDLProblem
from ltamp_cli.pddlstream.problem import Info
from ltamp_cli.planner.objects import value_key

MINIMIZE = "minimize"
GOAL_PREDICATE = "satisfaction-achieved"
VALUE_PREDICATE = "satisfaction-value-{}"
ACTION = "satisfaction-assign"


class SatisfactionProblem(NamedTuple):
    """Stream file text, stream bindings, initial facts and the terms to satisfy."""

    stream_pddl: str | Sequence[str]
    stream_map: Mapping[str, Callable[..., Any]]
    init: Iterable[tuple[Any, ...]]
    terms: Sequence[tuple[Any, ...]]


class SatisfactionSolution(NamedTuple):
    """``bindings`` (``?parameter`` → value; ``None`` when not solved), the summed value of
    the minimised functions (``inf`` when not solved) and the facts known at the end."""

    bindings: dict[str, Any] | None
    cost: float
    facts: list[tuple[Any, ...]]


def Minimize(head: tuple[Any, ...]) -> tuple[Any, ...]:
    """An objective term: minimise the function ``head`` (a tuple ``(name, arg, ...)``)."""
    return (MINIMIZE, head)


def is_parameter(value: Any) -> bool:
    """Whether ``value`` is a free parameter (a string starting with ``?``)."""
    return isinstance(value, str) and value.startswith("?")


class _Compiled(NamedTuple):
    problem: PDDLProblem
    parameters: tuple[str, ...]
    has_objectives: bool


def _pddl_name(word: Any, where: str) -> str:
    if not isinstance(word, str) or not word or any(c in word for c in "() \t\n;?"):
        raise InputError(f"{where}: expected a predicate or function name, got {word!r:.60}")
    return word


def compile_satisfaction(problem: SatisfactionProblem, costs: bool = True) -> _Compiled:
    """The satisfaction problem as a :class:`PDDLProblem` whose only action assigns every
    free parameter (see the module docstring). ``costs=False`` drops the objectives."""
    if not isinstance(problem, tuple) or len(problem) != 4:
        raise InputError("expected SatisfactionProblem(stream_pddl, stream_map, init, terms)")
    stream_pddl, stream_map, init, terms = problem
    parameters: dict[str, str] = {}  # PDDL name (lower-case) -> the user's spelling
    constants: dict[Any, str] = {}
    constant_values: list[Any] = []

    def argument(value: Any) -> str:
        if is_parameter(value):
            parameters.setdefault(value.lower(), value)
            return value.lower()
        key = value_key(value)
        if key not in constants:
            constants[key] = f"?satisfaction-constant-{len(constants)}"
            constant_values.append(value)
        return constants[key]

    def atom(fact: Any, where: str) -> str:
        if not isinstance(fact, tuple) or not fact:
            raise InputError(f"{where}: expected a fact tuple (predicate, arg, ...), got "
                             f"{fact!r:.60}")
        if isinstance(fact[0], str) and fact[0].lower() == "not" and len(fact) == 2:
            return f"(not {atom(fact[1], where)})"
        name = _pddl_name(fact[0], where)
        return "(" + " ".join([name, *(argument(v) for v in fact[1:])]) + ")"

    conditions: list[str] = []
    objectives: list[str] = []
    for index, term in enumerate(terms):
        where = f"satisfaction term {index}"
        if isinstance(term, tuple) and len(term) == 2 and isinstance(term[0], str) \
                and term[0].lower() == MINIMIZE:
            if costs:
                objectives.append(atom(term[1], where))
            continue
        conditions.append(atom(term, where))
    if not conditions and not objectives:
        raise InputError("SatisfactionProblem has no terms to satisfy")
    for index, key in enumerate(constants):
        conditions.append(f"({VALUE_PREDICATE.format(index)} {constants[key]})")
    names = [*parameters, *constants.values()]
    effects = [f"({GOAL_PREDICATE})", *(f"(increase (total-cost) {o})" for o in objectives)]
    domain = (
        "(define (domain satisfaction)\n"
        "  (:requirements :strips :action-costs)\n"
        f"  (:predicates ({GOAL_PREDICATE}))\n"
        f"  (:functions (total-cost) {_function_declarations(objectives)})\n"
        f"  (:action {ACTION}\n"
        f"    :parameters ({' '.join(names)})\n"
        f"    :precondition (and {' '.join(conditions)})\n"
        f"    :effect (and {' '.join(effects)})))\n")
    value_facts = [(VALUE_PREDICATE.format(i), v) for i, v in enumerate(constant_values)]
    compiled = PDDLProblem(domain, {}, stream_pddl, stream_map, [*init, *value_facts],
                           (GOAL_PREDICATE,))
    return _Compiled(compiled, tuple(parameters.values()), bool(objectives))


def _function_declarations(objectives: list[str]) -> str:
    arities: dict[str, int] = {}
    for objective in objectives:
        words = objective.strip("()").split()
        arities.setdefault(words[0].lower(), len(words) - 1)
    return " ".join("(" + " ".join([name, *(f"?a{i}" for i in range(arity))]) + ")"
                    for name, arity in arities.items())


def constraint_satisfaction(problem: SatisfactionProblem,
                            stream_info: Mapping[str, Info] | None = None, costs: bool = True,
                            success_cost: float = math.inf, max_time: float = math.inf,
                            algorithm: str = "adaptive", verbose: bool = True,
                            **ignored: Any) -> SatisfactionSolution:
    """Solve a :class:`SatisfactionProblem` with ltamp's planner (``adaptive`` unless told).

    ``costs=False`` ignores the ``minimize`` terms; ``success_cost``: keep improving until
    the summed objective is at most this (``inf``: the first assignment found);
    ``max_time`` in seconds. PDDLStream's search options are accepted and ignored.
    """
    from ltamp_cli.pddlstream.solve import solve

    compiled = compile_satisfaction(problem, costs)
    solution = solve(compiled.problem, algorithm=algorithm, stream_info=stream_info,
                     max_time=max_time, success_cost=success_cost, verbose=verbose)
    return assignment_from_solution(compiled, solution.plan, solution.cost,
                                    solution.certificate)


def assignment_from_solution(compiled: _Compiled, plan: Sequence[Any] | None, cost: float,
                             certificate: Certificate) -> SatisfactionSolution:
    """The bindings of the compiled problem's one plan step (``None`` if not solved)."""
    facts = [fact for fact in certificate.all_facts
             if not str(fact[0]).startswith("satisfaction-")]
    if not plan:
        return SatisfactionSolution(None, math.inf, facts)
    step = plan[0]
    bindings = dict(zip(compiled.parameters, step.args[:len(compiled.parameters)], strict=True))
    return SatisfactionSolution(bindings, cost if compiled.has_objectives else 0.0, facts)


def solve_pddlstream_satisfaction(problem: SatisfactionProblem, **options: Any
                                  ) -> SatisfactionSolution:
    """PDDLStream's planning-based satisfaction (``incremental=True``: the incremental
    algorithm); the same compilation as :func:`constraint_satisfaction`."""
    algorithm = "incremental" if options.pop("incremental", False) else \
        options.pop("algorithm", None) or "adaptive"
    return constraint_satisfaction(problem, algorithm=algorithm, **options)


def dump_assignment(solution: SatisfactionSolution) -> None:
    """Print whether it was solved, the cost and each binding (PDDLStream's format)."""
    bindings, cost, facts = solution
    print(f"\nSolved: {bindings is not None}")
    print(f"Cost: {cost:.3f}")
    print(f"Total facts: {len(facts)}")
    if bindings is None:
        return
    for parameter in sorted(bindings):
        print(f"{parameter} = {bindings[parameter]}")


__all__ = ["Minimize", "SatisfactionProblem", "SatisfactionSolution", "compile_satisfaction",
           "constraint_satisfaction", "dump_assignment", "is_parameter",
           "solve_pddlstream_satisfaction"]
