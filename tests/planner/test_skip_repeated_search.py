"""A budgeted search is not repeated on a task that grounds as one whose search ran out."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.search.solve import grounding_signature, plan_discrete

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"


def test_same_grounded_task_is_skipped_and_a_changed_one_is_searched() -> None:
    problem = load_problem(EXAMPLES / "blocksworld.yaml")
    objects = {name: type_name for name, (type_name, _) in problem.objects.items()}
    init = [(atom.predicate, *atom.args) for atom in problem.init]
    deadline = time.perf_counter() + 60

    def run(facts, skip=None):
        return plan_discrete(problem.domain, objects, facts, {}, problem.goal, deadline,
                             algorithm="lazy-greedy", max_expansions=1,
                             skip_if_grounded_as=skip)

    first = run(init)
    assert first.capped and not first.skipped  # 8 blocks: not solved in one expansion
    signature = grounding_signature(first.grounding)
    again = run(init, signature)
    assert again.skipped and again.capped and again.outcome.expanded == 0
    # A fact no action or axiom uses does not change the search: still skipped.
    assert run([*init, ("unused-fact", "x")], signature).skipped
    # Removing an initial fact changes the ground actions: not skipped.
    changed = run(init[1:], signature)
    assert grounding_signature(changed.grounding) != signature and not changed.skipped



@pytest.mark.parametrize("algorithm", ["focused", "binding", "adaptive"])
def test_algorithms_do_not_search_a_task_again_after_it_ran_out_of_budget(
        algorithm: str, monkeypatch: pytest.MonkeyPatch) -> None:
    # kitchen_symbolic seed 6: the first optimistic task runs out of budget, and raising
    # the complexity bound leaves it unchanged twice before it grows.
    from ltamp_cli.planner.algorithms import common
    from ltamp_cli.planner.algorithms.common import PlannerConfig
    from ltamp_cli.planner.api import solve

    searched: list[frozenset[object]] = []
    skipped = 0
    original = common.plan_discrete

    def spy(*args, **kwargs):  # type: ignore[no-untyped-def]
        nonlocal skipped
        result = original(*args, **kwargs)
        if result.skipped:
            skipped += 1
        elif result.capped:
            searched.append(grounding_signature(result.grounding))
        return result

    monkeypatch.setattr(common, "plan_discrete", spy)
    problem = load_problem(EXAMPLES / "kitchen_symbolic.yaml")
    options = {k: v for k, v in problem.planner_options.items() if k != "max_time"}
    result = solve(problem, PlannerConfig(algorithm=algorithm, seed=6, max_time=60, **options))
    assert result.solved
    assert searched and skipped  # the case arises, and a repeat was skipped
    assert len(set(searched)) == len(searched)
