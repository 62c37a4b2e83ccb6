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
    # Blocksworld has no streams: raising the complexity bound after a search that ran out
    # of its (here tiny) budget leaves the task as it was, up to the bound.
    from ltamp_cli.planner import api
    from ltamp_cli.planner.algorithms import common
    from ltamp_cli.planner.algorithms.common import PlannerConfig

    searched: list[frozenset[object]] = []
    skipped = 0
    original_search = common.plan_discrete
    original_state = api.initial_state

    def spy(*args, **kwargs):  # type: ignore[no-untyped-def]
        nonlocal skipped
        result = original_search(*args, **kwargs)
        if result.skipped:
            skipped += 1
        elif result.capped:
            searched.append(grounding_signature(result.grounding))
        return result

    def small_budget(*args, **kwargs):  # type: ignore[no-untyped-def]
        state = original_state(*args, **kwargs)
        state.search_budget = 4
        return state

    monkeypatch.setattr(common, "plan_discrete", spy)
    monkeypatch.setattr(api, "initial_state", small_budget)
    problem = load_problem(EXAMPLES / "blocksworld.yaml")
    # lazy-greedy: the budget bounds the whole search (hill-climbing's own steps are not).
    result = api.solve(problem, PlannerConfig(algorithm=algorithm, seed=0, max_time=60,
                                              max_complexity=3, search="lazy-greedy"))
    assert result.solved
    # Out of budget at complexity 0; the same task at 1 and 2 is skipped; at the bound (3)
    # it is searched again with a doubled budget, and again until solved.
    assert skipped == 2
    assert len(searched) == 3 and len(set(searched)) == 1
