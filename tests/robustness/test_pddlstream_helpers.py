"""Round 3: PDDLStream's example scripts, run unmodified against ``ltamp_cli.pddlstream``
through an import shim (an experiment outside the repository: ``examples/blocksworld``,
``advanced/{fluent,exogenous,adl,counting,wild,defer,multi_cost}`` and ``discrete_tamp``
solve), stopped at imports of helpers the drop-in module lacked: ``get_length``,
``is_plan``, ``partition_facts``, ``read_pddl_pair``, ``TOTAL_COST``, ``NOT``,
``MINIMIZE``... (``continuous_tamp``, ``cashpoint``, ``ipc/rovers``, ``ipc/satellites``).
They are provided now, written here from their documented behaviour; this script uses them
the way those examples do."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import ltamp_cli.pddlstream as api


def test_constants_have_pddlstream_values() -> None:
    assert (api.TOTAL_COST, api.EQ, api.AND, api.OR, api.NOT, api.MINIMIZE) == (
        "total-cost", "=", "and", "or", "not", "minimize")
    assert api.FAILED is None and api.INFEASIBLE is False


def test_plan_helpers() -> None:
    plan = [api.Action("move", (1, 2)), api.Action("pick", ("a",))]
    assert api.is_plan(plan) and api.get_length(plan) == 2
    assert api.is_plan([]) and api.get_length([]) == 0
    for failed in (None, False):
        assert not api.is_plan(failed) and api.get_length(failed) == math.inf
    assert "move" in api.str_from_plan(plan) and api.str_from_plan(None) == "None"
    fact = ("AtPose", "a", 1.0)
    assert api.get_prefix(fact) == "AtPose" and api.get_args(fact) == ("a", 1.0)


def test_partition_facts() -> None:
    facts = [("on", "a", "b"), ("not", ("clear", "a")), ("=", ("cost",), 3),
             ("minimize", ("dist", 1, 2)), ("handempty",)]
    positive, negated, functions = api.partition_facts(facts)
    assert positive == [("on", "a", "b"), ("handempty",)]
    assert negated == [("clear", "a")]
    assert functions == [("cost",), ("dist", 1, 2)]


def test_read_pairs_next_to_a_script(tmp_path: Path) -> None:
    for name in ("domain.pddl", "problem.pddl", "stream.pddl"):
        (tmp_path / name).write_text(f"; {name}\n")
    script = str(tmp_path / "run.py")
    domain, problem = api.read_pddl_pair(script)
    assert (domain, problem) == ("; domain.pddl\n", "; problem.pddl\n")
    assert domain.path == str(tmp_path / "domain.pddl")  # type: ignore[attr-defined]
    assert api.read_pddlstream_pair(script)[1] == "; stream.pddl\n"


def test_solve_with_the_helpers_as_an_example_script_would(tmp_path: Path) -> None:
    domain = """(define (domain hop) (:requirements :strips)
      (:predicates (At ?x) (Next ?x ?y))
      (:functions (total-cost))
      (:action hop :parameters (?x ?y) :precondition (and (At ?x) (Next ?x ?y))
        :effect (and (At ?y) (not (At ?x)) (increase (total-cost) 2))))"""
    init = [("At", 0), ("Next", 0, 1), ("Next", 1, 2), api.Equal((api.TOTAL_COST,), 0)]
    problem = api.PDDLProblem(domain, {}, None, {}, init, ("At", 2))
    solution = api.solve(problem, max_time=30, verbose=False)
    assert api.is_plan(solution.plan) and api.get_length(solution.plan) == 2
    assert solution.cost == pytest.approx(4.0)
