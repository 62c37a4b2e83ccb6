"""A grounded task compiled to integer facts and flat numpy arrays for fast search.

Fact 0 is always true and fact 1 always false; they pad empty precondition lists so that
``np.minimum.reduceat``/``np.maximum.reduceat`` work on every operator.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ltamp_cli.errors import InputError
from ltamp_cli.planner.search.clock import NO_DEADLINE, check_deadline
from ltamp_cli.planner.search.ground import Fact, GroundAction, GroundAxiom, Grounding
from ltamp_cli.planner.search.normalize import GOAL_PREDICATE

TRUE_FACT, FALSE_FACT = 0, 1
# Bytes of state vectors kept per task (one byte per fact and state); the cache is emptied
# when it would exceed this.
MAX_CACHED_VECTOR_BYTES = 50_000_000
# Operators encoded between two deadline checks.
DEADLINE_STRIDE = 256
GOAL_FACT: Fact = (GOAL_PREDICATE,)


def _flatten(lists: Sequence[Sequence[int]], pad: int) -> tuple[np.ndarray, np.ndarray]:
    """Concatenate integer lists (empty ones padded with ``pad``) and their start offsets."""
    starts = np.empty(len(lists), dtype=np.int64)
    flat: list[int] = []
    for i, items in enumerate(lists):
        starts[i] = len(flat)
        flat.extend(items if items else (pad,))
    return np.asarray(flat, dtype=np.int64), starts


@dataclass
class AxiomLayer:
    """One stratum of ground axioms as flat arrays (``reduceat`` layout, empty bodies padded
    with the always-true / always-false fact). ``recursive``: a positive body fact is a head
    of this stratum (then the layer iterates to a fixpoint, else one pass computes it);
    ``single_pos`` / ``single_neg``: every body has at most one positive / negated literal
    (then ``pos_flat`` / ``neg_flat`` hold one fact per axiom and a gather replaces the
    ``reduceat``)."""

    pos_flat: np.ndarray
    pos_starts: np.ndarray
    neg_flat: np.ndarray
    neg_starts: np.ndarray
    heads: np.ndarray
    recursive: bool = True
    single_pos: bool = False
    single_neg: bool = False


@dataclass
class ConditionalEffect:
    condition_pos: tuple[int, ...]
    condition_neg: tuple[int, ...]
    fact: int
    positive: bool


@dataclass
class Operator:
    action: GroundAction
    pre_pos: tuple[int, ...]
    pre_neg: tuple[int, ...]
    adds: tuple[int, ...]
    deletes: tuple[int, ...]
    conditional: tuple[ConditionalEffect, ...]
    cost: float


class Task:
    """Integer-encoded planning task: operators, stratified axioms, initial state, goal."""

    def __init__(self, grounding: Grounding, init: set[Fact],
                 deadline: float = NO_DEADLINE) -> None:
        self.facts: list[Fact] = [("%true",), ("%false",)]
        self.fact_ids: dict[Fact, int] = {}
        derived = set(grounding.derived_predicates) | {GOAL_PREDICATE}
        self.derived_predicates = frozenset(derived)
        self.operators = []
        for number, action in enumerate(grounding.actions):
            if number % DEADLINE_STRIDE == 0:
                check_deadline(deadline)
            self.operators.append(self._operator(action))
        self.axioms = grounding.axioms
        self.goal = self.fact_id(GOAL_FACT)
        axiom_heads = [self.fact_id(a.head) for a in grounding.axioms]
        axiom_pos = [[self.fact_id(f) for f in a.body_pos] for a in grounding.axioms]
        axiom_neg = [[self.fact_id(f) for f in a.body_neg] for a in grounding.axioms]
        self.init = frozenset(self.fact_ids[f] for f in init if f in self.fact_ids)
        self.num_facts = len(self.facts)
        self.is_derived = np.zeros(self.num_facts, dtype=bool)
        for fact, index in self.fact_ids.items():
            self.is_derived[index] = fact[0] in derived
        self._compile_operators()
        check_deadline(deadline)
        self._compile_axioms(axiom_heads, axiom_pos, axiom_neg)
        self._vectors: dict[frozenset[int], np.ndarray] = {}

    def fact_id(self, fact: Fact) -> int:
        index = self.fact_ids.get(fact)
        if index is None:
            index = len(self.facts)
            self.fact_ids[fact] = index
            self.facts.append(fact)
        return index

    def _operator(self, action: GroundAction) -> Operator:
        adds, deletes, conditional = [], [], []
        fact_id = self.fact_id
        for effect in action.effects:
            fact = fact_id(effect.fact)
            if effect.condition_pos or effect.condition_neg:
                conditional.append(ConditionalEffect(
                    tuple(map(fact_id, effect.condition_pos)),
                    tuple(map(fact_id, effect.condition_neg)),
                    fact, effect.positive))
            elif effect.positive:
                adds.append(fact)
            else:
                deletes.append(fact)
        return Operator(
            action,
            tuple(map(fact_id, action.pre_pos)),  # map: no generator frame per fact
            tuple(map(fact_id, action.pre_neg)),
            tuple(dict.fromkeys(adds)),
            tuple(dict.fromkeys(d for d in deletes if d not in adds)),
            tuple(conditional),
            action.cost,
        )

    def _compile_operators(self) -> None:
        self.pre_pos_flat, self.pre_pos_starts = _flatten(
            [op.pre_pos for op in self.operators], TRUE_FACT)
        self.pre_neg_flat, self.pre_neg_starts = _flatten(
            [op.pre_neg for op in self.operators], FALSE_FACT)
        self.costs = np.array([op.cost for op in self.operators], dtype=float)

    def _compile_axioms(self, heads: list[int], positive: list[list[int]],
                        negative: list[list[int]]) -> None:
        strata = _stratify(self.axioms)
        self.axiom_layers: list[AxiomLayer] = []
        for stratum in sorted(set(strata)):
            members = [i for i, s in enumerate(strata) if s == stratum]
            layer_heads = {heads[i] for i in members}
            pos_flat, pos_starts = _flatten([positive[i] for i in members], TRUE_FACT)
            neg_flat, neg_starts = _flatten([negative[i] for i in members], FALSE_FACT)
            self.axiom_layers.append(AxiomLayer(
                pos_flat, pos_starts, neg_flat, neg_starts,
                np.array([heads[i] for i in members], dtype=np.int64),
                recursive=any(f in layer_heads for i in members for f in positive[i]),
                single_pos=all(len(positive[i]) <= 1 for i in members),
                single_neg=all(len(negative[i]) <= 1 for i in members)))
        self.axiom_heads = heads
        self.axiom_positive = positive
        self.axiom_negative = negative

    def state_vector(self, state: frozenset[int]) -> np.ndarray:
        """Truth vector (read-only, ``(num_facts,)`` uint8) of a basic state, extended with
        its derived facts. Cached: searches, plan post-processing and preimages evaluate the
        same states again."""
        vector = self._vectors.get(state)
        if vector is None:
            if len(self._vectors) * self.num_facts >= MAX_CACHED_VECTOR_BYTES:
                self._vectors.clear()
            vector = self._compute_vector(state)
            vector.flags.writeable = False
            self._vectors[state] = vector
        return vector

    def _compute_vector(self, state: frozenset[int]) -> np.ndarray:
        vector = np.zeros(self.num_facts, dtype=np.uint8)
        vector[TRUE_FACT] = 1
        if state:
            vector[np.fromiter(state, dtype=np.int64, count=len(state))] = 1
        for layer in self.axiom_layers:
            heads = layer.heads
            if not len(heads):
                continue
            # Negated bodies are of lower strata: fixed within the layer.
            if layer.single_neg:
                free = vector[layer.neg_flat] == 0
            else:
                free = np.maximum.reduceat(vector[layer.neg_flat], layer.neg_starts) == 0
            while True:
                if layer.single_pos:
                    ready = vector[layer.pos_flat] > 0
                else:
                    ready = np.minimum.reduceat(vector[layer.pos_flat], layer.pos_starts) > 0
                ready &= free
                if not layer.recursive:
                    # No body fact is a head of this layer: one pass reaches the fixpoint.
                    vector[heads[ready]] = 1
                    break
                new = heads[ready]
                new = new[vector[new] == 0]
                if not len(new):
                    break
                vector[new] = 1
        return vector

    def applicable(self, vector: np.ndarray) -> np.ndarray:
        """Indices of operators applicable in the state whose truth vector is given."""
        if not self.operators:
            return np.empty(0, dtype=np.int64)
        ok = np.minimum.reduceat(vector[self.pre_pos_flat], self.pre_pos_starts) > 0
        ok &= np.maximum.reduceat(vector[self.pre_neg_flat], self.pre_neg_starts) == 0
        return np.flatnonzero(ok)

    def successor(self, state: frozenset[int], vector: np.ndarray, op_index: int
                  ) -> frozenset[int]:
        op = self.operators[op_index]
        if not op.conditional:
            # Two set copies instead of four (a state holds ~100 facts in TAMP tasks).
            kept = state.difference(op.deletes) if op.deletes else state
            return kept.union(op.adds) if op.adds else kept
        adds, deletes = set(op.adds), set(op.deletes)
        for effect in op.conditional:
            if all(vector[f] for f in effect.condition_pos) and not any(
                    vector[f] for f in effect.condition_neg):
                (adds if effect.positive else deletes).add(effect.fact)
        return frozenset((state - deletes) | adds)

    def is_goal(self, vector: np.ndarray) -> bool:
        return bool(vector[self.goal])


def _stratify(axioms: Sequence[GroundAxiom]) -> list[int]:
    """Stratum per axiom: negated derived predicates must be computed in a lower stratum."""
    predicates = {a.head[0] for a in axioms}
    level = dict.fromkeys(predicates, 0)
    edges = set()
    for axiom in axioms:
        for fact in axiom.body_pos:
            if fact[0] in predicates:
                edges.add((fact[0], axiom.head[0], 0))
        for fact in axiom.body_neg:
            if fact[0] in predicates:
                edges.add((fact[0], axiom.head[0], 1))
    for _ in range(len(predicates) + 1):
        changed = False
        for source, target, strict in edges:
            if level[target] < level[source] + strict:
                level[target] = level[source] + strict
                changed = True
        if not changed:
            return [level[a.head[0]] for a in axioms]
    raise InputError("derived predicates are not stratified: a derived predicate depends "
                     "negatively on itself")
