"""Plan post-processing: a detour that exists only to re-enable moving is bridged."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import pytest

from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.search.solve import plan_discrete

MakeProblem = Callable[..., Path]

# A robot may move once after each touch (PDDLStream's CanMove pattern): "move to a, touch
# a, move on to g" reaches the same state as "move to g" when the direct link exists.
ROBOT_DOMAIN = """
(define (domain robot)
  (:requirements :action-costs)
  (:constants g)
  (:predicates (At ?x) (Link ?x ?y) (CanMove) (Done))
  (:functions (total-cost))
  (:action move
    :parameters (?x ?y)
    :precondition (and (At ?x) (Link ?x ?y) (CanMove))
    :effect (and (At ?y) (not (At ?x)) (not (CanMove)) (increase (total-cost) 2)))
  (:action touch
    :parameters (?x)
    :precondition (At ?x)
    :effect (and (CanMove) (increase (total-cost) 1)))
  (:action finish
    :parameters ()
    :precondition (At g)
    :effect (and (Done) (increase (total-cost) 1))))
"""
DETOUR = [("move", ("s", "a")), ("touch", ("a",)), ("move", ("a", "g")), ("finish", ())]


def solve_guess(make_problem: MakeProblem, links: list[tuple[str, str]]
                ) -> list[tuple[str, tuple[str, ...]]]:
    init = ", ".join(['"(At s)"', '"(CanMove)"', *(f'"(Link {x} {y})"' for x, y in links)])
    problem = load_problem(make_problem(
        ROBOT_DOMAIN, f"domain: dom\nobjects: {{s: null, a: null}}\n"
        f"init: [{init}]\ngoal: (Done)\n"))
    objects = {name: type_name for name, (type_name, _) in problem.objects.items()}
    facts = [(atom.predicate, *atom.args) for atom in problem.init]
    result = plan_discrete(problem.domain, objects, facts, {}, problem.goal,
                           time.perf_counter() + 30, guess=DETOUR)
    assert result.actions is not None
    return [(action.name, action.args) for action in result.actions]


@pytest.mark.parametrize(("links", "expected"), [
    # The direct move replaces the three-action detour.
    ([("s", "a"), ("a", "g"), ("s", "g")], [("move", ("s", "g")), ("finish", ())]),
    # Without a direct link the detour is needed and stays.
    ([("s", "a"), ("a", "g")], DETOUR),
])
def test_detour_is_bridged_only_when_one_action_gets_across(
        make_problem: MakeProblem, links: list[tuple[str, str]],
        expected: list[tuple[str, tuple[str, ...]]]) -> None:
    assert solve_guess(make_problem, links) == expected
