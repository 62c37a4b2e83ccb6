"""The facts a discrete plan relies on (its preimage), including certificates of
negated derived preconditions such as ``(not (Unsafe ...))``."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping

import numpy as np

from ltamp_cli.planner.search.ground import Fact, GroundAxiom
from ltamp_cli.planner.search.solve import DiscreteResult
from ltamp_cli.planner.search.task import GOAL_FACT


def plan_preimage(result: DiscreteResult) -> tuple[set[Fact], set[Fact]]:
    """``(facts, cost terms)`` the plan of ``result`` depends on.

    Positive derived facts are explained by one axiom rule that fires; a negated derived fact
    by the static facts that block each of its rules that would otherwise fire (e.g. the
    collision-free certificates that keep ``Unsafe`` false). A conditional effect that fires
    in its step adds its condition, static facts included, as a precondition would.
    """
    assert result.task is not None and result.outcome is not None and result.actions is not None
    task, grounding = result.task, result.grounding
    axioms_by_head = defaultdict(list)
    for axiom in grounding.axioms:
        axioms_by_head[axiom.head].append(axiom)
    blocked_by_head = defaultdict(list)
    for head, dynamic, blocking in grounding.blocked_axioms:
        blocked_by_head[head].append((dynamic, blocking))
    preimage = _Preimage(task.fact_ids, task.derived_predicates, axioms_by_head,
                         blocked_by_head)
    cost_terms: set[Fact] = set()
    for step, action in enumerate(result.actions):
        vector = task.state_vector(result.outcome.states[step])
        seen: set[Fact] = set()
        preimage.needed.update(action.static_pre)
        for fact in action.pre_pos:
            preimage.support(fact, vector, seen)
        for fact in action.pre_neg:
            preimage.refute(fact, vector, seen)
        for effect in action.effects:
            # A conditional effect that fired relies on its condition as the step relies on
            # its precondition: its static facts (e.g. a test's ``(Hits ?q ?v)`` in a
            # ``when``) were only optimistic when the effect was ground, and a plan whose
            # goal needs the effect is wrong unless they are certified.
            if not (effect.static_pos or effect.condition_pos or effect.condition_neg):
                continue
            if all(preimage.holds(f, vector) for f in effect.condition_pos) and not any(
                    preimage.holds(f, vector) for f in effect.condition_neg):
                preimage.needed.update(effect.static_pos)
                for fact in effect.condition_pos:
                    preimage.support(fact, vector, seen)
                for fact in effect.condition_neg:
                    preimage.refute(fact, vector, seen)
        cost_terms.update(action.cost_terms)
    final = task.state_vector(result.outcome.states[-1])
    preimage.support(GOAL_FACT, final, set())
    return preimage.needed, cost_terms


class _Preimage:
    """The facts found so far (``needed``) and how to explain one more.

    A class rather than nested recursive functions: those form reference cycles (function,
    closure cell, function) that keep the whole task alive until the garbage collector
    traverses it, ~25 ms after every tamp2d_4blocks solve.
    """

    def __init__(self, fact_ids: Mapping[Fact, int], derived_predicates: frozenset[str],
                 axioms_by_head: Mapping[Fact, list[GroundAxiom]],
                 blocked_by_head: Mapping[Fact, list[tuple[tuple[Fact, ...], Fact]]]) -> None:
        self.fact_ids = fact_ids
        self.derived_predicates = derived_predicates
        self.axioms_by_head = axioms_by_head
        self.blocked_by_head = blocked_by_head
        self.needed: set[Fact] = set()

    def holds(self, fact: Fact, vector: np.ndarray) -> bool:
        index = self.fact_ids.get(fact)
        return index is not None and bool(vector[index])

    def support(self, fact: Fact, vector: np.ndarray, seen: set[Fact]) -> None:
        """Add what makes ``fact`` true in the state ``vector``."""
        if fact in seen:
            return
        seen.add(fact)
        if fact[0] not in self.derived_predicates:
            self.needed.add(fact)
            return
        for axiom in self.axioms_by_head.get(fact, ()):
            if all(self.holds(f, vector) for f in axiom.body_pos) and not any(
                    self.holds(f, vector) for f in axiom.body_neg):
                self.needed.update(axiom.static_pos)
                for positive in axiom.body_pos:
                    self.support(positive, vector, seen)
                for negative in axiom.body_neg:
                    self.refute(negative, vector, seen)
                return

    def refute(self, fact: Fact, vector: np.ndarray, seen: set[Fact]) -> None:
        """Add the static facts that keep the derived ``fact`` false in ``vector``."""
        if fact[0] not in self.derived_predicates or ("not", *fact) in seen:
            return
        seen.add(("not", *fact))
        for dynamic, blocking in self.blocked_by_head.get(fact, ()):
            if all(self.holds(f, vector) for f in dynamic):
                self.needed.add(blocking)
