"""Red-team round 9: an optimistic "infeasible" that rests on "every future stream output is
a new object" when the problem shows otherwise.

The merge-safe relaxation and the abstract task (:mod:`.multiplicity`,
:mod:`.abstract_task`) map every future output to a stand-in, never to an object the
problem gives. Round 8 left the grid (the goal cell is reachable only as a neighbour
stream's output) answered "infeasible" by adaptive, binding and focused. Now the proof is
refused, and the incremental completion runs, when a stream has output an object the
problem gives (evidence that outputs coincide with them) or when the goal names an object
that no initial fact mentions (only an output equal to it could bring it in).
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from pathlib import Path

import pytest

from ltamp_cli.pddlstream import PDDLProblem, from_list_fn
from ltamp_cli.pddlstream.problem import to_planning_problem
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem

GRID = """(define (domain grid) (:predicates (Cell ?c) (Adj ?c ?d) (At ?c))
  (:action move :parameters (?c ?d) :precondition (and (At ?c) (Adj ?c ?d))
    :effect (and (At ?d) (not (At ?c)))))"""
GRID_STREAM = """(define (stream grid) (:stream next :inputs (?c) :domain (Cell ?c)
  :outputs (?d) :certified (and (Cell ?d) (Adj ?c ?d))))"""


def _neighbours(cell: tuple[int, int]) -> list[tuple[tuple[int, int]]]:
    x, y = cell
    return [((x + 1, y),), ((x, y + 1),)] if x + y < 4 else []


ALGORITHMS = ["adaptive", "binding", "focused"]


@pytest.mark.parametrize("algorithm", ALGORITHMS)
@pytest.mark.parametrize("extra", [[], [("Cell", (1, 0)), ("Cell", (2, 2))]],
                         ids=["goal-only-cell", "an-output-is-a-given-cell"])
def test_the_grid_goal_reached_by_a_neighbour_stream_is_solved(
        algorithm: str, extra: list[tuple[str, tuple[int, int]]]) -> None:
    """(2, 2) is named only by the goal (round 8's grid), or also by an initial fact while
    ``next((0, 0))`` outputs (1, 0), a cell the problem gives: before, both "infeasible"
    in ~0.02 s ("merge-safe relaxation: goal unreachable")."""
    problem = to_planning_problem(PDDLProblem(
        GRID, {}, GRID_STREAM, {"next": from_list_fn(_neighbours)},
        [("Cell", (0, 0)), ("At", (0, 0)), *extra], ("At", (2, 2))))
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=30))
    assert result.status == "solved", (result.stats, result.diagnostics)
    assert len(result.plan) == 4
    assert "future output may equal an object" in result.stats["completed_by"]


HOP = """(define (domain hop)
  (:predicates (Pos ?p) (At ?p) (Next ?p ?q) (Good ?q))
  (:action hop :parameters (?p ?q) :precondition (and (At ?p) (Next ?p ?q) (Good ?q))
    :effect (and (At ?q) (not (At ?p)))))"""
HOP_STREAM = """(define (stream hop)
  (:stream next :inputs (?p) :domain (Pos ?p) :outputs (?q)
    :certified (and (Pos ?q) (Next ?p ?q)))
  (:stream good :inputs (?q) :domain (Pos ?q) :certified (Good ?q)))"""
HOP_BINDINGS = """
def make_streams(world, rng):
    def next_(p):
        for step in (1, 2, 3):
            yield (p + step,)
    return {"next": next_, "good": lambda q: q % 3 == 0}
"""


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_a_goal_object_only_a_stream_output_can_equal_is_reached(
        algorithm: str, make_problem: Callable[..., Path]) -> None:
    """tests/planner/test_features.py's hop problem with ``good`` true on multiples of 3:
    0-3-6-9 reaches p9 (value 9), which only ``next``'s output 9 brings in; before, the
    three optimistic algorithms answered "infeasible"."""
    path = make_problem(textwrap.dedent(HOP), "domain: dom\nbindings: bindings.py\n"
                        "objects: {p0: 0, p9: 9}\ninit: [\"(Pos p0)\", \"(At p0)\"]\n"
                        "goal: (and (At p9) (Good p9))\n", HOP_STREAM, HOP_BINDINGS)
    result = solve(load_problem(path), PlannerConfig(algorithm=algorithm, max_time=30))
    assert result.status == "solved", (result.stats, result.diagnostics)
    assert [step.values for step in result.plan] == [(0, 3), (3, 6), (6, 9)]
