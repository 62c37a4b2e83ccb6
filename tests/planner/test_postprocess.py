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


# Coffee with a greedy detour (#19, Kitchen3D coffee): stir, then pour (which undoes the
# stir), then stir again. Dropping any part of the first stir's detour breaks the actions
# after it (CanMove, and as in Kitchen3D an arm moves between a pick and a place: JustPicked,
# JustPlaced), so only the segment from the move to the stirrer to the move on to the cup
# can go, replaced by the direct move; the state after it then lacks (Stirred), which
# nothing reads before the last stir sets it.
COFFEE_DOMAIN = """
(define (domain coffee)
  (:requirements :action-costs :negative-preconditions)
  (:constants bowl)
  (:predicates (At ?x) (Link ?x ?y) (CanMove) (HandEmpty) (Holding ?o) (ObjAt ?o ?x)
               (Cup ?o) (Stirrer ?o) (Filled) (Stirred) (JustPicked) (JustPlaced))
  (:functions (total-cost))
  (:action move-free
    :parameters (?x ?y)
    :precondition (and (At ?x) (Link ?x ?y) (CanMove) (HandEmpty))
    :effect (and (At ?y) (not (At ?x)) (not (CanMove)) (not (JustPlaced))))
  (:action move-holding
    :parameters (?o ?x ?y)
    :precondition (and (Holding ?o) (At ?x) (Link ?x ?y) (CanMove))
    :effect (and (At ?y) (not (At ?x)) (not (CanMove)) (not (JustPicked))))
  (:action pick
    :parameters (?o ?x)
    :precondition (and (ObjAt ?o ?x) (At ?x) (HandEmpty) (not (JustPlaced)))
    :effect (and (Holding ?o) (not (ObjAt ?o ?x)) (not (HandEmpty)) (CanMove) (JustPicked)
                 (increase (total-cost) 1)))
  (:action place
    :parameters (?o ?x)
    :precondition (and (Holding ?o) (At ?x) (not (JustPicked)))
    :effect (and (ObjAt ?o ?x) (HandEmpty) (not (Holding ?o)) (CanMove) (JustPlaced)
                 (increase (total-cost) 1)))
  (:action pour
    :parameters (?o)
    :precondition (and (Holding ?o) (Cup ?o) (At bowl))
    :effect (and (Filled) (not (Stirred)) (CanMove) (increase (total-cost) 1)))
  (:action stir
    :parameters (?o)
    :precondition (and (Holding ?o) (Stirrer ?o) (At bowl))
    :effect (and (Stirred) (CanMove) (increase (total-cost) 1))))
"""
STIR_CUP_STIR = [
    ("move-free", ("home", "cs")), ("pick", ("stirrer", "cs")),
    ("move-holding", ("stirrer", "cs", "bowl")), ("stir", ("stirrer",)),
    ("move-holding", ("stirrer", "bowl", "cs")), ("place", ("stirrer", "cs")),
    ("move-free", ("cs", "cc")), ("pick", ("cup", "cc")),
    ("move-holding", ("cup", "cc", "bowl")), ("pour", ("cup",)),
    ("move-holding", ("cup", "bowl", "cc")), ("place", ("cup", "cc")),
    ("move-free", ("cc", "cs")), ("pick", ("stirrer", "cs")),
    ("move-holding", ("stirrer", "cs", "bowl")), ("stir", ("stirrer",))]


def test_a_stir_that_a_later_pour_undoes_is_bridged(make_problem: MakeProblem) -> None:
    places = ("home", "cs", "cc", "bowl")
    links = [f'"(Link {x} {y})"' for x in places for y in places if x != y]
    init = ", ".join(['"(At home)"', '"(CanMove)"', '"(HandEmpty)"', '"(Cup cup)"',
                      '"(Stirrer stirrer)"', '"(ObjAt cup cc)"', '"(ObjAt stirrer cs)"',
                      *links])
    problem = load_problem(make_problem(
        COFFEE_DOMAIN, "domain: dom\nobjects: {home: null, cs: null, cc: null, "
        f"cup: null, stirrer: null}}\ninit: [{init}]\ngoal: (and (Filled) (Stirred))\n"))
    objects = {name: type_name for name, (type_name, _) in problem.objects.items()}
    facts = [(atom.predicate, *atom.args) for atom in problem.init]
    result = plan_discrete(problem.domain, objects, facts, {}, problem.goal,
                           time.perf_counter() + 30, guess=STIR_CUP_STIR)
    assert result.actions is not None
    plan = [(action.name, action.args) for action in result.actions]
    assert plan == [("move-free", ("home", "cc")), *STIR_CUP_STIR[7:]]
