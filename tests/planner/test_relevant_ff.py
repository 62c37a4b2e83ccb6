"""The FF heuristic keeps only the relaxed operators that can support the goal (issue #19):
the same values and preferred operators as over every relaxed operator, on random tasks
(float costs, conditional effects, negated basic and derived conditions) and on the
states a kitchen_fluent solve evaluates, with fewer relaxed operators."""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest
from test_search_layout import random_task, recorded_evaluations

from ltamp_cli.planner.search.heuristic import INFINITY, FFHeuristic, HeuristicResult

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"


def same(task: object, vector: np.ndarray, cost_bias: float, unit_costs: bool
         ) -> tuple[HeuristicResult, HeuristicResult, int, int]:
    full = FFHeuristic(task, cost_bias=cost_bias, unit_costs=unit_costs,  # type: ignore[arg-type]
                       relevant_only=False)
    pruned = FFHeuristic(task, cost_bias=cost_bias, unit_costs=unit_costs)  # type: ignore[arg-type]
    return (full._evaluate(vector), pruned._evaluate(vector), len(full.relevant),
            len(pruned.relevant))


@pytest.mark.parametrize("unit_costs,cost_bias", [(False, 1.0), (False, 0.0), (True, 1.0)])
def test_pruned_ff_equals_ff_over_every_operator_on_random_tasks(unit_costs: bool,
                                                                 cost_bias: float) -> None:
    rng = random.Random(1)
    compared = finite = pruned_tasks = 0
    for _ in range(200):
        task, states = random_task(rng)
        for state in states:
            full, pruned, before, after = same(task, task.state_vector(state), cost_bias,
                                               unit_costs)
            assert (pruned.value, pruned.preferred) == (full.value, full.preferred)
            compared += 1
            finite += full.value not in (0.0, INFINITY)
        pruned_tasks += after < before
    assert compared == 1000 and finite > 250
    assert pruned_tasks > 50  # the comparison covers tasks that lost operators


def test_pruned_ff_equals_ff_over_every_operator_on_kitchen_fluent(
        monkeypatch: pytest.MonkeyPatch) -> None:
    recorded = recorded_evaluations(monkeypatch, "kitchen_fluent", "adaptive", seed=0)
    assert len(recorded) >= 100
    full_by_task: dict[int, FFHeuristic] = {}
    fewer = 0
    for heuristic, vector in recorded[::4]:
        full = full_by_task.get(id(heuristic))
        if full is None:
            full = full_by_task[id(heuristic)] = FFHeuristic(heuristic.task,
                                                             relevant_only=False)
            fewer += len(heuristic.relevant) < len(full.relevant)
        got, expected = heuristic._evaluate(vector), full._evaluate(vector)
        assert (got.value, got.preferred) == (expected.value, expected.preferred)
    assert fewer >= 1
