"""``analyze_goal`` (PDDLStream's ``pddlstream.algorithms.meta.analyze_goal``): the initial
facts the goal back-chains to (issue #18).

Own problem in PDDLStream's style. The expected answers were those of PDDLStream itself
(commit 2c7d6f5, Fast Downward's translator of caelan/downward 11e98c5) on the same
problem and options, run once by hand: PDDLStream is not a test dependency.
"""

from __future__ import annotations

import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream import And, Exists, PDDLProblem, analyze_goal, from_gen_fn, from_test

DOMAIN = """
(define (domain depot)
  (:requirements :strips :action-costs)
  (:predicates (Parcel ?p) (Spot ?s) (At ?s) (Depot ?s) (Drop ?p ?s) (Loaded ?p)
               (Delivered ?p ?s) (Wrapped ?p) (Ready ?p) (Broken ?p) (Route ?s1 ?s2))
  (:functions (Distance ?s1 ?s2))
  (:action drive :parameters (?s1 ?s2)
    :precondition (and (At ?s1) (Route ?s1 ?s2))
    :effect (and (At ?s2) (not (At ?s1)) (increase (total-cost) (Distance ?s1 ?s2))))
  (:action load :parameters (?p ?s)
    :precondition (and (Parcel ?p) (Depot ?s) (At ?s))
    :effect (and (Loaded ?p) (increase (total-cost) 1)))
  (:action pack :parameters (?p)
    :precondition (and (Parcel ?p) (Wrapped ?p)) :effect (Ready ?p))
  (:action unload :parameters (?p ?s)
    :precondition (and (Loaded ?p) (Drop ?p ?s) (At ?s) (Ready ?p) (not (Broken ?p)))
    :effect (and (Delivered ?p ?s) (not (Loaded ?p)) (increase (total-cost) 1))))
"""
STREAM = """
(define (stream depot)
  (:stream find-drop :inputs (?p) :domain (Parcel ?p) :outputs (?s)
    :certified (and (Spot ?s) (Drop ?p ?s)))
  (:stream check-route :inputs (?s1 ?s2) :domain (and (Spot ?s1) (Spot ?s2))
    :certified (Route ?s1 ?s2))
  (:function (Distance ?s1 ?s2) (and (Spot ?s1) (Spot ?s2))))
"""


def depot_problem(goal: object) -> PDDLProblem:
    init = [("Spot", "depot"), ("Depot", "depot"), ("At", "depot"), ("Parcel", "a"),
            ("Parcel", "b"), ("Wrapped", "a"), ("Broken", "b"), ("Spot", "spot2")]
    stream_map = {"find-drop": from_gen_fn(lambda p: iter([("spot2",)])),
                  "check-route": from_test(lambda s1, s2: True),
                  "distance": lambda s1, s2: 1.0}
    return PDDLProblem(DOMAIN, {}, STREAM, stream_map, init, goal)


DELIVERED = And(Exists(["?s"], ("Delivered", "a", "?s")), ("Ready", "a"))
# The route back is certified by check-route on the placeholder drop spot, whose find-drop
# instances (parcels a and b share its placeholder output) have the parcels as domain.
ROUTE_BACK = And(Exists(["?s"], And(("Delivered", "a", "?s"), ("Route", "?s", "depot"))),
                 ("Ready", "a"))
AT = ("at", "depot")
STREAM_FACTS = [("parcel", "a"), ("parcel", "b"), ("spot", "depot")]


@pytest.mark.parametrize(("goal", "options", "expected"), [
    (DELIVERED, {}, []),
    (DELIVERED, {"use_actions": True}, [AT]),
    (DELIVERED, {"use_actions": True, "blocked_predicates": ["AT"]}, []),
    (ROUTE_BACK, {}, STREAM_FACTS),
    (ROUTE_BACK, {"use_actions": True}, [AT, *STREAM_FACTS]),
    (ROUTE_BACK, {"use_actions": True, "blocked_predicates": ["at"]}, STREAM_FACTS),
    (ROUTE_BACK, {"use_actions": True, "use_streams": False}, [AT]),
    (ROUTE_BACK, {"use_axioms": False}, []),
    (ROUTE_BACK, {"use_actions": True, "unique": True, "debug": True}, [AT, *STREAM_FACTS]),
])
def test_goal_back_chains_as_in_pddlstream(goal: object, options: dict[str, object],
                                           expected: list[tuple[str, ...]]) -> None:
    assert analyze_goal(depot_problem(goal), **options) == expected


def test_a_ground_goal_is_its_own_literals(capsys: pytest.CaptureFixture[str]) -> None:
    """A conjunction of ground literals: back-chained without axioms; negated goals follow
    the actions that delete the fact."""
    goal = And(("Loaded", "a"), ("Ready", "a"))
    assert analyze_goal(depot_problem(goal), use_actions=True, use_axioms=False) == [AT]
    assert "Goals: [('loaded', 'a'), ('ready', 'a')]" in capsys.readouterr().out


def test_unknown_option_is_refused() -> None:
    with pytest.raises(InputError, match="analyze_goal\\(\\): unknown option 'use_action'"):
        analyze_goal(depot_problem(DELIVERED), use_action=True)
