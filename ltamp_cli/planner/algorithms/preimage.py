"""The facts a discrete plan relies on (its preimage), including certificates of
negated derived preconditions such as ``(not (Unsafe ...))``."""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from ltamp_cli.planner.search.ground import Fact
from ltamp_cli.planner.search.solve import DiscreteResult
from ltamp_cli.planner.search.task import GOAL_FACT


def plan_preimage(result: DiscreteResult) -> tuple[set[Fact], set[Fact]]:
    """``(facts, cost terms)`` the plan of ``result`` depends on.

    Positive derived facts are explained by one axiom rule that fires; a negated derived fact
    by the static facts that block each of its rules that would otherwise fire (e.g. the
    collision-free certificates that keep ``Unsafe`` false).
    """
    assert result.task is not None and result.outcome is not None and result.actions is not None
    task, grounding = result.task, result.grounding
    axioms_by_head = defaultdict(list)
    for axiom in grounding.axioms:
        axioms_by_head[axiom.head].append(axiom)
    blocked_by_head = defaultdict(list)
    for head, dynamic, blocking in grounding.blocked_axioms:
        blocked_by_head[head].append((dynamic, blocking))
    needed: set[Fact] = set()
    cost_terms: set[Fact] = set()

    def holds(fact: Fact, vector: np.ndarray) -> bool:
        index = task.fact_ids.get(fact)
        return index is not None and bool(vector[index])

    def support(fact: Fact, vector: np.ndarray, seen: set[Fact]) -> None:
        if fact in seen:
            return
        seen.add(fact)
        if fact[0] not in task.derived_predicates:
            needed.add(fact)
            return
        for axiom in axioms_by_head[fact]:
            if all(holds(f, vector) for f in axiom.body_pos) and not any(
                    holds(f, vector) for f in axiom.body_neg):
                needed.update(axiom.static_pos)
                for positive in axiom.body_pos:
                    support(positive, vector, seen)
                for negative in axiom.body_neg:
                    refute(negative, vector, seen)
                return

    def refute(fact: Fact, vector: np.ndarray, seen: set[Fact]) -> None:
        if fact[0] not in task.derived_predicates or ("not", *fact) in seen:
            return
        seen.add(("not", *fact))
        for dynamic, blocking in blocked_by_head[fact]:
            if all(holds(f, vector) for f in dynamic):
                needed.add(blocking)

    for step, action in enumerate(result.actions):
        vector = task.state_vector(result.outcome.states[step])
        seen: set[Fact] = set()
        needed.update(action.static_pre)
        for fact in action.pre_pos:
            support(fact, vector, seen)
        for fact in action.pre_neg:
            refute(fact, vector, seen)
        if action.cost_term is not None:
            cost_terms.add(action.cost_term)
    final = task.state_vector(result.outcome.states[-1])
    support(GOAL_FACT, final, set())
    return needed, cost_terms
