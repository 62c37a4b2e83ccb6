"""The FF heuristic (relaxed plan from additive-cost best supporters), vectorised.

Relaxed operators are the task's operators (one per conditional effect too) and its axioms
(cost 0); negative conditions are ignored. Costs are propagated Bellman-Ford style with
``reduceat`` over flat arrays, which is fast for the task sizes TAMP produces.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ltamp_cli.planner.search.task import TRUE_FACT, Task, _flatten

INFINITY = float("inf")


@dataclass
class HeuristicResult:
    value: float
    preferred: list[int]  # indices of task operators in the relaxed plan


MAX_NEGATION_RULES = 64
# Heuristic values remembered per heuristic object (a state vector's bytes -> result); the
# memo is emptied when its keys would exceed this many bytes.
MAX_MEMO_BYTES = 50_000_000


class FFHeuristic:
    """h_FF with costs ``cost + cost_bias`` (``cost_bias=1`` is FD's plusone guidance).

    A negated derived condition ``not D`` gets its own relaxed fact ``¬D``, achieved when
    every rule of ``D`` is blocked by a fact that its negative body literals name (as Fast
    Downward compiles negated axioms); without it, goals such as ``forall m: (Contains cup
    m)`` — compiled to ``not aux`` — would look satisfied to the relaxation.
    """

    def __init__(self, task: Task, cost_bias: float = 1.0, unit_costs: bool = False,
                 relevant_only: bool = True) -> None:
        self.task = task
        preconditions: list[list[int]] = []
        self.effects: list[list[int]] = []
        costs: list[float] = []
        self.origin: list[int] = []  # task operator index, or -1 for an axiom
        negation, derived_rules, deleters = self._negations(task)

        def relaxed(positive: tuple[int, ...], negative: tuple[int, ...]) -> list[int]:
            return list(positive) + [negation[f] for f in negative if f in negation]

        for index, op in enumerate(task.operators):
            cost = (1.0 if unit_costs else op.cost + cost_bias)
            base = relaxed(op.pre_pos, op.pre_neg)
            preconditions.append(base)
            self.effects.append(list(op.adds))
            costs.append(cost)
            self.origin.append(index)
            for effect in op.conditional:
                if effect.positive:
                    preconditions.append(
                        base + relaxed(effect.condition_pos, effect.condition_neg))
                    self.effects.append([effect.fact])
                    costs.append(cost)
                    self.origin.append(index)
        for head, body, axiom in zip(task.axiom_heads, task.axiom_positive, task.axioms,
                                     strict=True):
            negative = tuple(task.fact_ids[f] for f in axiom.body_neg)
            preconditions.append(relaxed(tuple(body), negative))
            self.effects.append([head])
            costs.append(0.0)
            self.origin.append(-1)
        for fact, rules in derived_rules.items():
            for rule in rules:
                preconditions.append(list(rule))
                self.effects.append([negation[fact]])
                costs.append(0.0)
                self.origin.append(-1)
        for fact, ops in deleters.items():
            for index in ops:
                op = task.operators[index]
                preconditions.append(relaxed(op.pre_pos, op.pre_neg))
                self.effects.append([negation[fact]])
                costs.append(1.0 if unit_costs else op.cost + cost_bias)
                self.origin.append(index)
        self.num_facts = task.num_facts + len(negation)
        self.negated_sources = np.array(list(negation), dtype=np.int64)
        self.negated_ids = np.array(list(negation.values()), dtype=np.int64)
        self.preconditions = preconditions
        self.pre_flat, self.pre_starts = _flatten(preconditions, TRUE_FACT)
        self.costs = np.asarray(costs, dtype=float)
        self._cost_list = self.costs.tolist()  # per-element reads are faster from a list
        # Cost propagation runs over the relaxed operators that can support the goal (see
        # goal_relevant); the lists above keep every relaxed operator, numbered as built.
        self.relevant = (goal_relevant(task.goal, preconditions, self.effects)
                         if relevant_only else list(range(len(preconditions))))
        achievers: dict[int, list[int]] = {}
        for op_index in self.relevant:
            for fact in self.effects[op_index]:
                achievers.setdefault(fact, []).append(op_index)
        self.achiever_facts = np.array(sorted(achievers), dtype=np.int64)
        self.achievers = achievers
        lists = [achievers[f] for f in self.achiever_facts]
        self.ach_flat, self.ach_starts = _flatten(lists, 0)
        # Segment (position in achiever_facts) of every ach_flat entry, for picking each
        # fact's best supporter with array operations.
        counts = np.diff(np.append(self.ach_starts, len(self.ach_flat)))
        self.ach_segment = np.repeat(np.arange(len(lists)), counts)
        self.ach_counts = counts
        self.has_ops = len(self.relevant) > 0
        self._compile_layout()
        self._memo: dict[bytes, HeuristicResult] = {}

    def _compile_layout(self) -> None:
        """Arrays for :meth:`_evaluate`'s cost propagation, laid out so that each round
        needs few and cheap numpy calls (``reduceat`` costs per segment, and in TAMP tasks
        most relaxed operators have one precondition and most facts one achiever).

        Relaxed operators are renumbered internally: those with at most one precondition
        first (their cost is one gather, ``single_pre``), then the others, whose
        preconditions are ``(width, n)`` matrices, one per width class (up to 2, 4, 8, ...),
        padded with the always-true fact (cost 0)
        and summed along axis 0 (row by row, so in the same order as a ``reduceat`` over
        the lists: the same floats). Only the goal-relevant operators (:attr:`relevant`)
        get an internal number. Achieved facts are reordered likewise: facts with one
        achiever first (a gather, ``single_ach``), then the others (a ``minimum.reduceat``
        over their achievers, each list in its original order, so that the first achiever
        of minimal cost is the same operator). ``order`` maps internal operator numbers to
        the original ones; ``fact_order`` lists the achieved facts in internal order."""
        lengths = [len(p) for p in self.preconditions]
        order = [i for i in self.relevant if lengths[i] <= 1]
        self.num_single_pre = len(order)
        # Longer precondition lists grouped by width class (up to 2, 4, 8, ...
        # preconditions), one padded matrix per class: one very long list (a negated derived
        # fact blocked by thousands of rules) must not pad every column to its length, while
        # padding stays below 2x the lists' total length.
        multi = sorted((i for i in self.relevant if lengths[i] > 1),
                       key=lambda i: (lengths[i] - 1).bit_length())
        order += multi
        self.order = np.asarray(order, dtype=np.int64)
        internal = np.full(len(lengths), -1, dtype=np.int64)
        internal[self.order] = np.arange(len(order), dtype=np.int64)
        self.single_pre = np.array(
            [self.preconditions[i][0] if self.preconditions[i] else TRUE_FACT
             for i in order[:self.num_single_pre]], dtype=np.int64)
        # (first, end, matrix): internal operators first..end-1 sum the matrix's columns.
        self.multi_pre_blocks: list[tuple[int, int, np.ndarray]] = []
        first = self.num_single_pre
        for _, members in itertools.groupby(multi, key=lambda i: (lengths[i] - 1).bit_length()):
            group = list(members)
            matrix = np.full((max(lengths[i] for i in group), len(group)), TRUE_FACT,
                             dtype=np.int64)
            for column, i in enumerate(group):
                matrix[:lengths[i], column] = self.preconditions[i]
            self.multi_pre_blocks.append((first, first + len(group), matrix))
            first += len(group)
        self.internal_costs = self.costs[self.order]
        facts = self.achiever_facts.tolist()
        singles = [f for f in facts if len(self.achievers[f]) == 1]
        multis = [f for f in facts if len(self.achievers[f]) > 1]
        self.fact_order = np.array(singles + multis, dtype=np.int64)
        self.num_single_ach = len(singles)
        self.single_facts = np.array(singles, dtype=np.int64)
        self.single_ach = np.array([internal[self.achievers[f][0]] for f in singles],
                                   dtype=np.int64)
        self.single_ach_original = np.array([self.achievers[f][0] for f in singles],
                                            dtype=np.int64)
        lists = [[int(internal[o]) for o in self.achievers[f]] for f in multis]
        self.multi_facts = np.array(multis, dtype=np.int64)
        self.multi_ach, self.multi_ach_starts = _flatten(lists, 0)
        self.multi_ach_original = self.order[self.multi_ach]
        self.multi_ach_counts = np.array([len(x) for x in lists], dtype=np.int64)
        self.multi_ach_segment = np.repeat(np.arange(len(lists)), self.multi_ach_counts)
        # Position in ``best`` (fact_order) of the fact each multi_ach entry achieves.
        self._multi_best = self.num_single_ach + self.multi_ach_segment
        # Supporters of the facts with one achiever, the same in every state.
        self._supporter_base = np.full(self.num_facts, -1, dtype=np.int64)
        self._supporter_base[self.single_facts] = self.single_ach_original
        self._cost_of = np.array([INFINITY, 0.0])  # by whether a fact holds

    @staticmethod
    def _negations(task: Task) -> tuple[dict[int, int], dict[int, list[list[int]]],
                                        dict[int, list[int]]]:
        """Relaxed ``¬F`` facts for facts used negatively, with how to achieve them.

        A derived ``D`` is false when every rule of ``D`` is blocked: a rule is blocked by
        making one of its positive basic literals false (``¬P``) or one of its negated
        literals true; a rule with a positive derived literal is assumed blockable for free.
        A basic ``P`` is made false by any operator that deletes it. Returns the id of each
        ``¬F``, the conjunctions achieving each ``¬D`` (over fact ids; ids that have a
        negation stand for ``¬P``), and the deleting operators of each basic ``P``.
        """
        used: set[int] = set()
        for op in task.operators:
            used.update(op.pre_neg)
            for effect in op.conditional:
                used.update(effect.condition_neg)
        for axiom in task.axioms:
            used.update(task.fact_ids[f] for f in axiom.body_neg)
        rules_of: dict[int, list[tuple[list[int], list[int]]]] = {}
        for head, axiom in zip(task.axiom_heads, task.axioms, strict=True):
            rules_of.setdefault(head, []).append(
                ([task.fact_ids[f] for f in axiom.body_pos],
                 [task.fact_ids[f] for f in axiom.body_neg]))
        negated_basic: set[int] = {f for f in used if not task.is_derived[f]}
        derived_rules: dict[int, list[list[int]]] = {}
        for fact in sorted(f for f in used if task.is_derived[f]):
            conjunctions: list[list[int]] = [[]]
            for positive, negative in rules_of.get(fact, []):
                if any(task.is_derived[f] for f in positive):
                    continue  # blockable for free
                options = [*positive, *negative]  # ¬P for positive ones, X for negated ones
                if not options:
                    conjunctions = []  # a rule that always fires: ¬D is unreachable
                    break
                conjunctions = [[*c, o] for c in conjunctions for o in options]
                if len(conjunctions) > MAX_NEGATION_RULES:
                    conjunctions = [[]]  # too many combinations: no guidance for this fact
                    break
            derived_rules[fact] = conjunctions
            for conjunction in conjunctions:
                positive_sets = {f for p, _ in rules_of.get(fact, []) for f in p}
                negated_basic.update(f for f in conjunction if f in positive_sets)
        ids = sorted(set(derived_rules) | negated_basic)
        negation = {fact: task.num_facts + i for i, fact in enumerate(ids)}
        # In rules, an option that came from a positive literal means ¬P; one from a negated
        # literal means X itself. Rewrite to explicit ids now that ¬P ids exist.
        for fact, conjunctions in derived_rules.items():
            positive_sets = {f for p, _ in rules_of.get(fact, []) for f in p}
            derived_rules[fact] = [
                [negation[f] if f in positive_sets else f for f in conjunction]
                for conjunction in conjunctions]
        deleters: dict[int, list[int]] = {f: [] for f in negated_basic}
        for index, op in enumerate(task.operators):
            for fact in op.deletes:
                if fact in deleters:
                    deleters[fact].append(index)
            for effect in op.conditional:
                if not effect.positive and effect.fact in deleters:
                    deleters[effect.fact].append(index)
        return negation, derived_rules, deleters

    def __call__(self, vector: np.ndarray) -> HeuristicResult:
        # Memoised per state: enforced hill-climbing, its local searches and the greedy
        # search it falls back to evaluate many of the same states.
        key = vector.tobytes()
        result = self._memo.get(key)
        if result is None:
            if len(self._memo) * len(key) >= MAX_MEMO_BYTES:
                self._memo.clear()
            result = self._evaluate(vector)
            self._memo[key] = result
        return result

    def _evaluate(self, vector: np.ndarray) -> HeuristicResult:
        """h_add costs by Bellman-Ford rounds until no fact gets cheaper, then the relaxed
        plan of the goal. Each round computes every relaxed operator's cost (its
        preconditions' costs plus its own) and every achieved fact's cheapest achiever,
        kept when cheaper than the fact's cost in the state (0 or infinite). Fact costs
        only decrease from round to round, so that minimum equals the one with the previous
        round's cost (the textbook update): the same costs, in fewer numpy calls."""
        task = self.task
        if vector[task.goal]:
            return HeuristicResult(0.0, [])
        if not self.has_ops or not len(self.achiever_facts):
            return HeuristicResult(INFINITY, [])
        holds = np.zeros(self.num_facts, dtype=np.intp)
        holds[: task.num_facts] = vector
        if len(self.negated_ids):
            holds[self.negated_ids] = vector[self.negated_sources] == 0
        holds[TRUE_FACT] = 1
        fact_cost = self._cost_of[holds]  # 0.0 where the fact holds, else infinite
        facts, split, singles = self.fact_order, self.num_single_ach, self.num_single_pre
        base = fact_cost[facts]
        current = base
        single_pre, multi_pre_blocks, costs = (self.single_pre, self.multi_pre_blocks,
                                               self.internal_costs)
        single_ach, multi_ach = self.single_ach, self.multi_ach
        multi_starts = self.multi_ach_starts
        has_multi_ach = len(multi_starts) > 0
        op_cost = np.empty(len(costs))
        best = np.empty(len(facts))
        candidate_costs = op_cost[multi_ach]
        for _ in range(self.num_facts + 1):
            fact_cost.take(single_pre, out=op_cost[:singles])
            for first, end, matrix in multi_pre_blocks:
                np.add.reduce(fact_cost[matrix], axis=0, out=op_cost[first:end])
            op_cost += costs
            op_cost.take(single_ach, out=best[:split])
            if has_multi_ach:
                candidate_costs = op_cost[multi_ach]
                np.minimum.reduceat(candidate_costs, multi_starts, out=best[split:])
            if not np.count_nonzero(best < current):  # a C call, unlike ndarray.any()
                break
            current = np.minimum(best, base)
            fact_cost[facts] = current
        if fact_cost[task.goal] == INFINITY:
            return HeuristicResult(INFINITY, [])
        # Facts of cost 0 hold already (or are reached by cost-0 axioms from what holds).
        return self._relaxed_plan(self._best_supporters(candidate_costs, best).tolist(),
                                  (fact_cost == 0.0).tolist())

    def _best_supporters(self, candidate_costs: np.ndarray, best: np.ndarray) -> np.ndarray:
        """Per fact, its first achiever of minimal cost (-1: none), as ``(num_facts,)``
        original relaxed-operator numbers. ``best``: the last round's cheapest achiever
        cost per achieved fact (in :attr:`fact_order`); ``candidate_costs``: the costs of
        the achievers of the facts with several."""
        supporters = self._supporter_base.copy()
        if len(self.multi_ach_starts):
            hits = np.flatnonzero(candidate_costs == best[self._multi_best])
            segments = self.multi_ach_segment[hits]
            first = np.ones(len(hits), dtype=bool)
            first[1:] = segments[1:] != segments[:-1]
            supporters[self.multi_facts[segments[first]]] = self.multi_ach_original[
                hits[first]]
        return supporters

    def _relaxed_plan(self, supporters: list[int], zero: list[bool]) -> HeuristicResult:
        """The relaxed plan of the goal from each fact's best supporter (``supporters``,
        relaxed-operator numbers by fact) and which facts cost nothing (``zero``)."""
        chosen: set[int] = set()
        marked: set[int] = set()
        stack = [self.task.goal]
        while stack:
            fact = stack.pop()
            if fact in marked or zero[fact]:
                continue
            marked.add(fact)
            supporter = supporters[fact]
            if supporter in chosen:
                continue
            chosen.add(supporter)
            stack.extend(self.preconditions[supporter])
        costs = self._cost_list
        value = float(sum(map(costs.__getitem__, chosen)))  # the set's order, as before
        holds = zero.__getitem__
        origin, preconditions = self.origin, self.preconditions
        preferred = sorted({origin[i] for i in chosen
                            if origin[i] >= 0 and all(map(holds, preconditions[i]))})
        return HeuristicResult(value, preferred)


def goal_relevant(goal: int, preconditions: Sequence[Sequence[int]],
                  effects: Sequence[Sequence[int]]) -> list[int]:
    """Relaxed operators (ascending numbers) that can support ``goal``: those adding the
    goal or a precondition of one that can, found backwards from the goal (relevance
    analysis of the relaxed task).

    h_FF is the same over these alone: a relevant fact's achievers are all relevant (they
    add it) and so are their preconditions, so the relevant facts get the same h_add costs
    and the same first cheapest achievers (the achiever lists keep their order), and the
    relaxed plan, which only visits relevant facts, is the same, with the same operator
    numbers (its cost is summed in the same order). Only irrelevant facts' costs, which
    nothing reads, are no longer computed. kitchen_fluent: 5-10 % of the relaxed operators
    and ~30 % of the facts are irrelevant (facts of placeholders that no goal-relevant
    action takes, deleters of negated facts no relevant condition reads)."""
    achievers: dict[int, list[int]] = {}
    for index, adds in enumerate(effects):
        for fact in adds:
            achievers.setdefault(fact, []).append(index)
    relevant = bytearray(len(preconditions))
    seen = {goal}
    stack = [goal]
    while stack:
        for index in achievers.get(stack.pop(), ()):
            if relevant[index]:
                continue
            relevant[index] = 1
            for fact in preconditions[index]:
                if fact not in seen:
                    seen.add(fact)
                    stack.append(fact)
    return [index for index, flag in enumerate(relevant) if flag]
