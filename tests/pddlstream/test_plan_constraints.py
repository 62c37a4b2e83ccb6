"""PDDLStream's plan constraints through the drop-in API: ``PlanConstraints(skeletons,
groups, exact, max_cost)``, ``OrderedSkeleton`` and ``WILD`` (issue #18).

Own problem in PDDLStream's style: a courier loads two parcels at the depot (x = 0) and
unloads each at a drop spot a stream proposes (parcel a: x = 2 or 5; parcel b: x = 5 or 8);
driving costs the distance, loading and unloading 1 each. The cheapest plans cost 9.
"""

from __future__ import annotations

import numpy as np
import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream import (
    GOAL_INDEX,
    WILD,
    And,
    Exists,
    OrderedSkeleton,
    PDDLProblem,
    PlanConstraints,
    Solution,
    from_gen_fn,
    solve,
)

DOMAIN = """
(define (domain courier)
  (:requirements :strips :action-costs)
  (:predicates (Parcel ?p) (Spot ?s) (At ?s) (Depot ?s) (Drop ?p ?s) (Loaded ?p)
               (Delivered ?p ?s))
  (:functions (Distance ?s1 ?s2))
  (:action drive :parameters (?s1 ?s2)
    :precondition (and (At ?s1) (Spot ?s1) (Spot ?s2))
    :effect (and (At ?s2) (not (At ?s1)) (increase (total-cost) (Distance ?s1 ?s2))))
  (:action load :parameters (?p ?s)
    :precondition (and (Parcel ?p) (Depot ?s) (At ?s))
    :effect (and (Loaded ?p) (increase (total-cost) 1)))
  (:action unload :parameters (?p ?s)
    :precondition (and (Loaded ?p) (Drop ?p ?s) (At ?s))
    :effect (and (Delivered ?p ?s) (not (Loaded ?p)) (increase (total-cost) 1))))
"""
STREAM = """
(define (stream courier)
  (:stream find-drop :inputs (?p) :domain (Parcel ?p) :outputs (?s)
    :certified (and (Spot ?s) (Drop ?p ?s)))
  (:function (Distance ?s1 ?s2) (and (Spot ?s1) (Spot ?s2))))
"""
DROPS = {"a": (2.0, 5.0), "b": (5.0, 8.0)}


def drops(parcel: str):  # type: ignore[no-untyped-def]
    for x in DROPS[parcel]:
        yield (np.array([x]),)


def courier() -> PDDLProblem:
    depot = np.array([0.0])
    init = [("Spot", depot), ("Depot", depot), ("At", depot), ("Parcel", "a"),
            ("Parcel", "b")]
    goal = And(Exists(["?s"], ("Delivered", "a", "?s")), Exists(["?t"], ("Delivered", "b", "?t")))
    stream_map = {"find-drop": from_gen_fn(drops),
                  "distance": lambda s1, s2: abs(float(s1[0] - s2[0]))}
    return PDDLProblem(DOMAIN, {}, STREAM, stream_map, init, goal)


def run(constraints: object, algorithm: str = "adaptive",
        max_time: float = 20) -> Solution:
    return solve(courier(), algorithm=algorithm, constraints=constraints, max_time=max_time,
                 verbose=False)


def unloads(solution: Solution) -> list[tuple[str, float]]:
    assert solution.plan is not None, "no plan"
    return [(a.args[0], float(a.args[1][0])) for a in solution.plan if a.name == "unload"]


@pytest.mark.parametrize("algorithm", ["adaptive", "focused", "incremental"])
def test_a_shared_variable_puts_both_parcels_at_one_spot(algorithm: str) -> None:
    """Not exact: other actions come between; ``?s`` is one object in both steps."""
    skeleton = [("unload", ["a", "?s"]), ("unload", ["b", "?s"])]
    solution = run(PlanConstraints(skeletons=[skeleton], exact=False), algorithm)
    assert unloads(solution) == [("a", 5.0), ("b", 5.0)]


def test_exact_plan_is_one_of_the_skeletons() -> None:
    """The first skeleton cannot reach the goal (b is never delivered): the plan is the
    second, step for step."""
    impossible = [("load", ["a", WILD]), ("unload", ["a", WILD])]
    together = [("load", ["a", "?d"]), ("load", ["b", "?d"]), ("drive", ["?d", "?s"]),
                ("unload", ["b", "?s"]), ("unload", ["a", "?s"])]
    solution = run(PlanConstraints(skeletons=[impossible, together], exact=True))
    assert solution.plan is not None
    assert [a.name for a in solution.plan] == ["load", "load", "drive", "unload", "unload"]
    assert unloads(solution) == [("b", 5.0), ("a", 5.0)]


def test_exact_skeleton_that_cannot_reach_the_goal_has_no_plan() -> None:
    """A correct "no plan": exact, the only skeleton never delivers b."""
    solution = run(PlanConstraints(skeletons=[[("load", ["a", WILD]), ("unload", ["a", WILD])]]),
                   max_time=10)
    assert solution.plan is None


def test_group_and_a_value_no_stream_has_made_yet() -> None:
    """``groups``: an argument naming a group is any of its values; x = 8 is no object
    until ``find-drop`` yields it, and that output is then the skeleton's object."""
    far = np.array([8.0])
    constraints = PlanConstraints(skeletons=[[("unload", ["b", "far"])]],
                                  groups={"far": [far]}, exact=False)
    assert ("b", 8.0) in unloads(run(constraints))
    direct = PlanConstraints(skeletons=[[("unload", ["b", far])]], exact=False)
    assert ("b", 8.0) in unloads(run(direct))


def test_ordered_skeleton_orders_steps() -> None:
    """b before a: the unconstrained cheapest plans deliver a first or both at 5."""
    skeleton = OrderedSkeleton([("unload", ["b", "?s"]), ("unload", ["a", "?t"])],
                               {(0, 1), (1, GOAL_INDEX)})
    solution = run(PlanConstraints(skeletons=[skeleton], exact=False))
    order = [name for name, _ in unloads(solution)]
    assert order.index("b") < order.index("a")


def test_unordered_steps_share_a_variable() -> None:
    """Two steps with no order between them: whichever comes first binds ``?s``."""
    skeleton = OrderedSkeleton([("unload", ["a", "?s"]), ("unload", ["b", "?s"])],
                               {(0, GOAL_INDEX), (1, GOAL_INDEX)})
    spots = {x for _, x in unloads(run(PlanConstraints(skeletons=[skeleton], exact=False)))}
    assert spots == {5.0}


def test_max_cost_bounds_the_plan_cost() -> None:
    """Plans must cost less than ``max_cost`` (PDDLStream: Fast Downward's bound); the
    cheapest cost 9, so 9 admits none: that "no plan" is right."""
    assert run(PlanConstraints(max_cost=9.5)).cost == 9
    assert run(PlanConstraints(max_cost=9), max_time=10).plan is None
    with pytest.raises(InputError, match="max cost with unit costs is not supported"):
        solve(courier(), constraints=PlanConstraints(max_cost=3), unit_costs=True,
              verbose=False)


@pytest.mark.parametrize(("constraints", "message"), [
    (PlanConstraints(skeletons=[[("unlod", ["a", WILD])]]), "skeleton pattern 'unlod': the "
     "domain has no such action"),
    (PlanConstraints(skeletons=[[("unload", ["a"])]]), "gives 1 argument(s); the action takes 2"),
    (PlanConstraints(skeletons=[]), "PlanConstraints(skeletons=[]): no plan follows"),
    (PlanConstraints(skeletons=[OrderedSkeleton([("load", [WILD, WILD])], {(0, 0)})]),
     "cycle"),
    (PlanConstraints(skeletons=[OrderedSkeleton([("load", [WILD, WILD])], {(0, 3)})]),
     "order (0, 3) names no step"),
    (PlanConstraints(skeletons=[["load"]]), "skeleton #1: step 'load' is no (action name"),
    ([("load", [WILD, WILD])], "constraints: expected PlanConstraints("),
    (PlanConstraints(max_cost=-1), "max cost: expected a number >= 0"),
    (PlanConstraints(skeletons=[OrderedSkeleton([("load", [WILD, WILD])], {"ab"})]),
     "orders must be pairs of step indices"),
])
def test_bad_constraints_are_refused_in_one_line(constraints: object,
                                                 message: str) -> None:
    with pytest.raises(InputError) as caught:
        run(constraints, max_time=5)
    assert message in str(caught.value) and "\n" not in str(caught.value)
