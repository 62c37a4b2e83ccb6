"""The FF heuristic (relaxed plan from additive-cost best supporters), vectorised.

Relaxed operators are the task's operators (one per conditional effect too) and its axioms
(cost 0); negative conditions are ignored. Costs are propagated Bellman-Ford style with
``reduceat`` over flat arrays, which is fast for the task sizes TAMP produces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ltamp_cli.planner.search.task import TRUE_FACT, Task, _flatten

INFINITY = float("inf")


@dataclass
class HeuristicResult:
    value: float
    preferred: list[int]  # indices of task operators in the relaxed plan


class FFHeuristic:
    """h_FF with costs ``cost + cost_bias`` (``cost_bias=1`` is FD's plusone guidance)."""

    def __init__(self, task: Task, cost_bias: float = 1.0, unit_costs: bool = False) -> None:
        self.task = task
        preconditions: list[list[int]] = []
        self.effects: list[list[int]] = []
        costs: list[float] = []
        self.origin: list[int] = []  # task operator index, or -1 for an axiom
        for index, op in enumerate(task.operators):
            cost = (1.0 if unit_costs else op.cost + cost_bias)
            preconditions.append(list(op.pre_pos))
            self.effects.append(list(op.adds))
            costs.append(cost)
            self.origin.append(index)
            for effect in op.conditional:
                if effect.positive:
                    preconditions.append(list(op.pre_pos) + list(effect.condition_pos))
                    self.effects.append([effect.fact])
                    costs.append(cost)
                    self.origin.append(index)
        for head, body in zip(task.axiom_heads, task.axiom_positive, strict=True):
            preconditions.append(list(body))
            self.effects.append([head])
            costs.append(0.0)
            self.origin.append(-1)
        self.preconditions = preconditions
        self.pre_flat, self.pre_starts = _flatten(preconditions, TRUE_FACT)
        self.costs = np.asarray(costs, dtype=float)
        achievers: dict[int, list[int]] = {}
        for op_index, adds in enumerate(self.effects):
            for fact in adds:
                achievers.setdefault(fact, []).append(op_index)
        self.achiever_facts = np.array(sorted(achievers), dtype=np.int64)
        self.achievers = achievers
        lists = [achievers[f] for f in self.achiever_facts]
        self.ach_flat, self.ach_starts = _flatten(lists, 0)
        self.has_ops = len(preconditions) > 0

    def __call__(self, vector: np.ndarray) -> HeuristicResult:
        task = self.task
        if vector[task.goal]:
            return HeuristicResult(0.0, [])
        fact_cost = np.where(vector > 0, 0.0, INFINITY)
        fact_cost[TRUE_FACT] = 0.0
        if not self.has_ops or not len(self.achiever_facts):
            return HeuristicResult(INFINITY, [])
        op_cost = self.costs
        for _ in range(task.num_facts + 1):
            op_cost = np.add.reduceat(fact_cost[self.pre_flat], self.pre_starts) + self.costs
            best = np.minimum.reduceat(op_cost[self.ach_flat], self.ach_starts)
            current = fact_cost[self.achiever_facts]
            improved = best < current
            if not improved.any():
                break
            fact_cost[self.achiever_facts[improved]] = best[improved]
        if fact_cost[task.goal] == INFINITY:
            return HeuristicResult(INFINITY, [])
        return self._relaxed_plan(vector, fact_cost, op_cost)

    def _relaxed_plan(self, vector: np.ndarray, fact_cost: np.ndarray, op_cost: np.ndarray
                      ) -> HeuristicResult:
        chosen: set[int] = set()
        marked: set[int] = set()
        stack = [self.task.goal]
        while stack:
            fact = stack.pop()
            if fact in marked or vector[fact]:
                continue
            marked.add(fact)
            candidates = self.achievers[fact]
            supporter = min(candidates, key=lambda i: op_cost[i])
            if supporter in chosen:
                continue
            chosen.add(supporter)
            stack.extend(self.preconditions[supporter])
        value = float(sum(self.costs[i] for i in chosen))
        preferred = sorted({
            self.origin[i] for i in chosen
            if self.origin[i] >= 0 and all(vector[f] for f in self.preconditions[i])
        })
        return HeuristicResult(value, preferred)
