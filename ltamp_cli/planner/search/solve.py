"""One discrete planning call: normalise, ground, compile and search."""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from ltamp_cli.planner.pddl.syntax import OBJECT_TYPE, Domain, Formula
from ltamp_cli.planner.search.clock import check_deadline
from ltamp_cli.planner.search.engine import SearchOutcome, run_search, weighted_astar
from ltamp_cli.planner.search.ground import (
    Context,
    Fact,
    GroundAction,
    Grounding,
    forbid_contexts,
    ground_task,
    require_fluent_contexts,
)
from ltamp_cli.planner.search.incremental import GroundingCache
from ltamp_cli.planner.search.normalize import NormalAction, NormalAxiom, Normalizer, type_predicate
from ltamp_cli.planner.search.skeleton import PlanConstraints, constrain
from ltamp_cli.planner.search.task import Task


@dataclass
class DiscreteResult:
    actions: list[GroundAction] | None
    cost: float
    grounding: Grounding
    task: Task | None
    outcome: SearchOutcome | None
    ground_time_s: float
    search_time_s: float
    # No search ran: the grounded task equalled ``skip_if_grounded_as`` (see plan_discrete).
    skipped: bool = False

    @property
    def solved(self) -> bool:
        return self.actions is not None

    @property
    def capped(self) -> bool:
        """Not solved only because the search's expansion budget ran out."""
        return self.outcome is not None and self.outcome.capped


def grounding_signature(grounding: Grounding) -> frozenset[object]:
    """What a search of a grounded task depends on besides the initial state's fluents:
    the ground actions (with their static preconditions) and the axioms of the derived
    facts that actions or the goal use, directly or through other axioms (axioms about
    values no action uses, e.g. new optimistic poses, do not change the search)."""
    by_head: dict[Fact, list[object]] = {}
    for axiom in grounding.axioms:
        by_head.setdefault(axiom.head, []).append(axiom)
    needed: list[Fact] = [("%goal",)]
    for action in grounding.actions:
        needed.extend(action.pre_pos)
        needed.extend(action.pre_neg)
        for effect in action.effects:
            needed.extend(effect.condition_pos)
            needed.extend(effect.condition_neg)
    used: set[object] = set()
    seen: set[Fact] = set()
    while needed:
        fact = needed.pop()
        if fact in seen:
            continue
        seen.add(fact)
        for axiom in by_head.get(fact, ()):
            used.add(axiom)
            needed.extend(axiom.body_pos)  # type: ignore[attr-defined]
            needed.extend(axiom.body_neg)  # type: ignore[attr-defined]
    return frozenset((*grounding.actions, *used))


def normalized_task(domain: Domain, objects: Mapping[str, str], init: Iterable[Fact],
                    goal: Formula, deadline: float
                    ) -> tuple[list[NormalAction], list[NormalAxiom], set[Fact]]:
    """The domain's actions and axioms (the goal's ``%goal`` axioms included) in normal
    form, and the initial facts with each object's type facts, ready for grounding."""
    closure = type_closure(domain)
    objects_by_type: dict[str, list[str]] = {}
    facts = set(init)
    for name, type_name in objects.items():
        for ancestor in closure.get(type_name, [type_name, OBJECT_TYPE]):
            objects_by_type.setdefault(ancestor, []).append(name)
            facts.add((type_predicate(ancestor), name))
    normalizer = Normalizer(objects_by_type)
    actions = [variant for action in domain.actions for variant in normalizer.action(action)]
    check_deadline(deadline)
    axioms = [rule for axiom in domain.axioms for rule in normalizer.axiom(axiom)]
    check_deadline(deadline)
    axioms += normalizer.goal(goal)
    changing = ({effect.predicate for action in actions for effect in action.effects}
                | {axiom.head.name for axiom in domain.axioms})
    axioms += normalizer.take_auxiliary(
        lambda predicate: predicate not in changing and not predicate.startswith("%"))
    return actions, axioms, facts


def type_closure(domain: Domain) -> dict[str, list[str]]:
    """Each type's ancestors (itself included, and ``object``)."""
    parents = domain.type_parents()
    closure: dict[str, list[str]] = {}
    for type_name in {OBJECT_TYPE, *parents, *parents.values()}:
        chain, current = [], type_name
        while current is not None and current not in chain:
            chain.append(current)
            current = parents.get(current)
        if OBJECT_TYPE not in chain:
            chain.append(OBJECT_TYPE)
        closure[type_name] = chain
    return closure


def plan_discrete(
    domain: Domain,
    objects: Mapping[str, str],
    init: Iterable[Fact],
    function_values: Mapping[Fact, float],
    goal: Formula,
    deadline: float,
    algorithm: str = "ff",
    unit_costs: bool = False,
    max_expansions: int | None = None,
    skeleton: PlanConstraints | None = None,
    cost_bound: float | None = None,
    fluent_requirements: Mapping[Fact, Sequence[Context]] | None = None,
    context_blocks: Mapping[Fact, Sequence[Context]] | None = None,
    guess: Sequence[tuple[str, tuple[str, ...]]] | None = None,
    skip_if_grounded_as: frozenset[object] | None = None,
    grounding_cache: GroundingCache | None = None,
) -> DiscreteResult:
    """Find a plan for the finite task given by ``objects`` (name → type) and ``init``.

    ``skeleton`` constrains the plan to follow one of its skeletons (see
    :mod:`.skeleton`); ``cost_bound`` asks for a plan cheaper than it (weighted A* then).
    ``guess``: a candidate plan (action name, arguments) checked before searching; when
    it reaches the goal in this task it is the plan (after action elimination), else the
    search runs as usual (ignored with ``skeleton`` or ``cost_bound``).
    ``skip_if_grounded_as``: a :func:`grounding_signature` of a task whose search ran out of
    budget; when this task grounds to the same, no search runs (``skipped``, reported as
    capped): it would repeat that search.
    ``grounding_cache``: the caller's :class:`.GroundingCache` (one per solve), which grounds
    successive tasks without redoing the joins; the grounding is the same without it.
    """
    start = time.perf_counter()
    actions, axioms, facts = normalized_task(domain, objects, init, goal, deadline)
    if grounding_cache is not None:
        grounding = grounding_cache.ground(actions, axioms, facts, function_values, deadline)
    else:
        grounding = ground_task(actions, axioms, facts, function_values, deadline)
    if fluent_requirements:
        grounding = require_fluent_contexts(grounding, fluent_requirements, deadline)
    if context_blocks:
        grounding = forbid_contexts(grounding, context_blocks, deadline)
    ground_time = time.perf_counter() - start
    if ("%goal",) not in grounding.reachable:
        return DiscreteResult(None, float("inf"), grounding, None, None, ground_time, 0.0)
    if (skip_if_grounded_as is not None and not skeleton
            and grounding_signature(grounding) == skip_if_grounded_as):
        outcome = SearchOutcome(None, float("inf"), 0, 0, 0.0, capped=True)
        return DiscreteResult(None, float("inf"), grounding, None, outcome, ground_time, 0.0,
                              skipped=True)
    if skeleton:
        grounding = constrain(grounding, skeleton)
    task = Task(grounding, facts, deadline)
    if cost_bound is not None:
        outcome = weighted_astar(task, deadline, cost_bound=cost_bound, unit_costs=unit_costs)
    else:
        outcome = run_search(task, algorithm, deadline, unit_costs=unit_costs,
                             max_expansions=max_expansions,
                             guess=None if skeleton else guess)
    search_time = time.perf_counter() - start - ground_time
    if outcome.plan is None:
        return DiscreteResult(None, float("inf"), grounding, task, outcome, ground_time,
                              search_time)
    plan = [task.operators[i].action for i in outcome.plan]
    cost = float(sum(action.cost for action in plan))  # real costs, without search effort
    return DiscreteResult(plan, cost, grounding, task, outcome, ground_time, search_time)
