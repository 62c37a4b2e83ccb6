"""PDDLStream's ``analyze_goal``: which initial facts the goal back-chains to.

The goal is traced back, in a relaxed space, through what could make each of its literals
true: the axioms deriving a fact (``use_axioms``), the actions adding it or, for a negated
literal, deleting it (``use_actions``; conditions whose predicate is in
``blocked_predicates`` are not followed), and the stream results certifying it
(``use_streams``). Streams are evaluated as in PDDLStream, optimistically: each stream yields
one placeholder per output, whatever its inputs (PDDLStream's default optimistic outputs;
its ``unique`` option changes only the real debug values, which this analysis never uses),
to a fixpoint, and the task is grounded over the facts so reached; static conditions of actions
(predicates no action changes) are not followed, as Fast Downward's grounding
drops them in PDDLStream. The answer is the set of initial facts reached, as value tuples
sorted by predicate.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping
from typing import Any

from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream.language import SHARED_DEBUG, PDDLProblem
from ltamp_cli.pddlstream.problem import to_planning_problem
from ltamp_cli.planner.algorithms.common import (
    PlannerConfig,
    PlannerState,
    certified_facts,
    external_domain,
    external_inputs,
    initial_state,
    instantiate_atoms,
)
from ltamp_cli.planner.pddl.syntax import And, Atom, Not
from ltamp_cli.planner.search.ground import Fact, Grounding, ground_task
from ltamp_cli.planner.search.normalize import GOAL_PREDICATE
from ltamp_cli.planner.search.solve import normalized_task

Literal = tuple[bool, Fact]  # (positive, fact)


def analyze_goal(problem: PDDLProblem, use_actions: bool = False, use_axioms: bool = True,
                 use_streams: bool = True, blocked_predicates: Iterable[str] = (),
                 max_time: float = 60.0, **options: Any
                 ) -> list[tuple[Any, ...]] | None:
    """The initial facts the goal of ``problem`` back-chains to (PDDLStream's
    ``pddlstream.algorithms.meta.analyze_goal``); prints ``Goals:`` and ``Initial:`` as it
    does. ``max_time`` (s) bounds the optimistic stream evaluation. PDDLStream's other
    options (``unique``, ``debug``, ``verbose``, ``normalize``, ``unit_costs``) change
    nothing here."""
    unknown = sorted(set(options) - {"unique", "debug", "verbose", "normalize", "unit_costs"})
    if unknown:
        raise InputError(f"analyze_goal(): unknown option {unknown[0]!r}")
    if isinstance(blocked_predicates, str):
        raise InputError("analyze_goal(): blocked_predicates must be a list of predicate "
                         f"names, got the string {blocked_predicates!r:.40}")
    blocked = {str(name).lower() for name in blocked_predicates}
    debug_problem = PDDLProblem(*problem[:3], SHARED_DEBUG, *problem[4:])
    planning = to_planning_problem(debug_problem)
    state = initial_state(planning, PlannerConfig(max_time=max_time))
    results = _optimistic_closure(state)
    actions, axioms, facts = normalized_task(
        planning.domain, state.object_types, state.facts.members, planning.goal,
        state.deadline)
    grounding = ground_task(actions, axioms, facts, state.function_values, state.deadline)
    causes = _causes(grounding, results if use_streams else [], use_actions, use_axioms,
                     blocked)
    # A conjunction of ground literals is the goal itself; any other goal is a derived
    # fact whose axioms are followed with use_axioms (PDDLStream: Fast Downward's goal axiom).
    goals = _ground_literals(planning.goal) or [(True, (GOAL_PREDICATE,))]
    print("Goals:", [_as_values(state, literal) for literal in dict.fromkeys(goals)])
    reached = _back_chain(goals, causes)
    init = {(atom.predicate, *atom.args) for atom in planning.init}
    found = sorted((_as_values(state, (True, fact)) for positive, fact in reached
                    if positive and fact in init and not fact[0].startswith("%")),
                   key=lambda fact: (fact[0], repr(fact[1:])))
    print("Initial:", found)
    return found


def _optimistic_closure(state: PlannerState) -> list[tuple[list[Fact], list[Fact]]]:
    """Call every stream instance (placeholder procedures) to a fixpoint; each result as
    (its domain facts, the facts it certified)."""
    results: list[tuple[list[Fact], list[Fact]]] = []
    changed = True
    while changed and time.perf_counter() < state.deadline:  # finite: shared placeholders
        before = len(state.facts.members)
        for external in state.externals.values():  # functions too: actions need costs
            for inputs in state.new_bindings(external, "analysis"):
                instance = state.instance(external.name, inputs)
                mapping = dict(zip(external_inputs(external), inputs, strict=True))
                domain = instantiate_atoms(external_domain(external), mapping)
                outputs = state.call(instance)
                if instance.is_test:
                    outputs = [()] if instance.value else []
                results.extend((domain, certified_facts(instance, output))
                               for output in outputs)
        changed = len(state.facts.members) != before
    return results


def _body(positive: Iterable[Fact], negative: Iterable[Fact]) -> list[Literal]:
    return [*((True, f) for f in positive), *((False, f) for f in negative)]


def _causes(grounding: Grounding, results: list[tuple[list[Fact], list[Fact]]],
            use_actions: bool, use_axioms: bool, blocked: set[str]
            ) -> dict[Literal, set[Literal]]:
    """For each literal, the conditions of what could make it true. As in PDDLStream, whose
    grounding (Fast Downward's) drops the static conditions of actions (those no action
    changes), those are not followed; an axiom's and a stream result's are."""
    static = grounding.static_predicates
    causes: dict[Literal, set[Literal]] = {}
    for axiom in grounding.axioms:
        if use_axioms:  # static conditions included: the goal axiom's are followed
            causes.setdefault((True, axiom.head), set()).update(
                _body((*axiom.body_pos, *axiom.static_pos), axiom.body_neg))
    if use_actions:
        for action in grounding.actions:
            for effect in action.effects:
                conditions = _body((*action.pre_pos, *effect.condition_pos),
                                   (*action.pre_neg, *effect.condition_neg))
                causes.setdefault((effect.positive, effect.fact), set()).update(
                    c for c in conditions if c[1][0] not in blocked | static)
    for domain, certified in results:
        for fact in certified:
            causes.setdefault((True, fact), set()).update((True, f) for f in domain)
    return causes


def _back_chain(goals: Iterable[Literal], causes: Mapping[Literal, set[Literal]]
                ) -> set[Literal]:
    reached: set[Literal] = set()
    stack = list(goals)
    while stack:
        literal = stack.pop()
        if literal not in reached:
            reached.add(literal)
            stack.extend(causes.get(literal, ()))
    return reached


def _ground_literals(goal: Any) -> list[Literal] | None:
    """The literals of a goal that is a conjunction of ground literals, else ``None``."""
    parts = goal.parts if isinstance(goal, And) else (goal,)
    literals: list[Literal] = []
    for part in parts:
        positive = not isinstance(part, Not)
        atom = part if positive else part.part
        if not isinstance(atom, Atom) or any(a.startswith("?") for a in atom.args):
            return None
        literals.append((positive, (atom.predicate, *atom.args)))
    return literals


def _as_values(state: PlannerState, literal: Literal) -> tuple[Any, ...]:
    positive, fact = literal
    values = (fact[0], *(state.objects.value(name) if name in state.objects else name
                         for name in fact[1:]))
    return values if positive else ("not", values)


__all__ = ["analyze_goal"]
