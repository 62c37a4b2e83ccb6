"""The full search after a refinement of shared placeholders, bounded by the refined
search's effort (``skeletons.REFINED_SEARCH_FACTOR``; opt-in, off by default: it made the
unseeded continuous_tamp's plans costlier more often).

A plan that needs one shared optimistic output as two different values is discarded and its
instances get their own placeholders (``optimistic.bindable_stream_plan``); the next search
is of nearly the same task. When that task has a plan it needs about as many expansions as
the refined one (kitchen_fluent: 61 -> 103); when it has none at this complexity the search
used to run to the whole budget (PDDLStream's ``kitchen/run.py`` under ltamp: 601
expansions, 0.16 of 0.40 s CPU) before the bounds were raised.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from ltamp_cli.planner.algorithms import common, skeletons
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"


def _record(monkeypatch: pytest.MonkeyPatch) -> tuple[list[dict[str, Any]], list[int]]:
    """Every search of the solve (its bound, whether budgeted, its expansions) and the
    index of each search whose plan was refined (``bindable_stream_plan`` returned None)."""
    searches: list[dict[str, Any]] = []
    refined: list[int] = []
    search = common.PlannerState.search

    def logged(state: Any, init: Any, objects: Any, function_values: Any,
               max_expansions: int | None = None, context_blocks: Any = None,
               budgeted: bool = False, guess: Any = None,
               skip_if_grounded_as: Any = None) -> Any:
        result = search(state, init, objects, function_values, max_expansions,
                        context_blocks, budgeted, guess, skip_if_grounded_as)
        searches.append({"max": max_expansions, "budgeted": budgeted,
                         "real": objects is state.object_types,
                         "expanded": result.outcome.expanded if result.outcome else 0,
                         "guessed": bool(result.outcome and result.outcome.guessed),
                         "capped": result.capped})
        return result

    bindable = skeletons.bindable_stream_plan

    def watched(*args: Any, **kwargs: Any) -> Any:
        found = bindable(*args, **kwargs)
        if found is None:
            refined.append(len(searches) - 1)
        return found

    monkeypatch.setattr(common.PlannerState, "search", logged)
    monkeypatch.setattr(skeletons, "bindable_stream_plan", watched)
    return searches, refined


@pytest.mark.parametrize("algorithm", ["adaptive", "binding"])
@pytest.mark.parametrize("seed", [0, 3])
def test_the_search_after_a_refinement_is_bounded_by_the_refined_one(
        algorithm: str, seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(skeletons, "REFINED_SEARCH_FACTOR", 4)
    problem = load_problem(EXAMPLES / "kitchen_fluent.yaml")
    searches, refined = _record(monkeypatch)
    result = solve(problem, PlannerConfig(algorithm=algorithm, seed=seed, max_time=60))
    assert result.solved
    assert validate_plan(problem, result).valid
    # kitchen_fluent's first plan uses one shared skill configuration for three tools
    assert refined, searches
    for index in refined:
        parent, after = searches[index], searches[index + 1]
        assert not after["real"]
        bound = max(skeletons.SPECULATIVE_MIN_EXPANSIONS,
                    skeletons.REFINED_SEARCH_FACTOR * parent["expanded"])
        # not budgeted (a bound it runs out of does not double the budget), bounded
        assert not after["budgeted"], (index, searches)
        assert after["max"] is not None and after["max"] <= bound, (index, searches)


def test_a_refined_search_that_runs_out_of_its_bound_still_leads_to_a_plan(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # With a bound far below what the refined task needs, the search after the refinement
    # runs out; the bounds are raised as after a full search that found nothing and the
    # solve goes on to a valid plan. (Lazy greedy: ``max_expansions`` bounds all of it;
    # the default enforced hill-climbing bounds only its greedy fallback.)
    monkeypatch.setattr(skeletons, "REFINED_SEARCH_FACTOR", 1)
    monkeypatch.setattr(skeletons, "SPECULATIVE_MIN_EXPANSIONS", 5)
    problem = load_problem(EXAMPLES / "kitchen_fluent.yaml")
    searches, refined = _record(monkeypatch)
    result = solve(problem, PlannerConfig(algorithm="adaptive", seed=0, max_time=60,
                                          search="lazy-greedy"))
    assert result.solved and validate_plan(problem, result).valid
    after = [searches[i + 1] for i in refined]
    assert any(s["capped"] for s in after), (refined, searches)


def test_off_by_default_the_search_after_a_refinement_is_a_full_one(
        monkeypatch: pytest.MonkeyPatch) -> None:
    assert skeletons.REFINED_SEARCH_FACTOR == 0
    problem = load_problem(EXAMPLES / "kitchen_fluent.yaml")
    searches, refined = _record(monkeypatch)
    result = solve(problem, PlannerConfig(algorithm="adaptive", seed=0, max_time=60))
    assert result.solved and refined
    assert all(searches[i + 1]["budgeted"] and searches[i + 1]["max"] is None
               for i in refined), searches
