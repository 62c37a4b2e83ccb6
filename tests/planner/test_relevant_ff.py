"""The FF heuristic keeps only the relaxed operators that can support the goal (issue #19):
the same values and preferred operators as over every relaxed operator, on random tasks
(float costs, conditional effects, negated basic and derived conditions) and on the
states a kitchen_fluent solve evaluates, with fewer relaxed operators."""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest
from test_search_layout import random_task

from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.search import heuristic as heuristic_module
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
    recorded: list[tuple[FFHeuristic, np.ndarray]] = []
    original = FFHeuristic._evaluate

    def spy(self: FFHeuristic, vector: np.ndarray) -> HeuristicResult:
        recorded.append((self, vector.copy()))
        return original(self, vector)

    monkeypatch.setattr(heuristic_module.FFHeuristic, "_evaluate", spy)
    problem = load_problem(EXAMPLES / "kitchen_fluent.yaml")
    options = {k: v for k, v in problem.planner_options.items()
               if k in PlannerConfig.__dataclass_fields__}
    config = PlannerConfig(**{**options, "algorithm": "adaptive", "seed": 0,
                              "max_time": 60.0, "statistics_dir": None})
    assert solve(problem, config).solved
    monkeypatch.setattr(heuristic_module.FFHeuristic, "_evaluate", original)
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
