"""A ``:fluents`` stream instance that a plan needs at two steps in different states.

The courier problem (written for this test, PDDLStream style): a robot carries two items,
one at a time, from the store to the counter. A wall between them has two gaps; a barrier
stands in one of them, and serving an item at the counter moves the barrier to the other
gap. The motion stream (``:fluents (BarrierAt)``) routes through the free gap, north first.
The plan drives store -> counter twice with the same inputs, first with the barrier in
the south gap (route through the north gap), then with it in the north gap: the first
call's route is invalid for the second drive, which needs its own call in its own state.
Each (instance, context) is called once and each plan step takes its own output, so the
first fully bound skeleton is a plan (before the fix the stream was called in the first
state only, the bound plan failed and a 500-expansion search over real facts ran in vain).
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pytest

from ltamp_cli.pddlstream import PDDLProblem, from_fn, from_test, read, solve
from ltamp_cli.pddlstream.solve import to_planning_problem
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve as plan

DOMAIN = """
(define (domain courier)
  (:requirements :strips)
  (:predicates (Conf ?q) (AtConf ?q) (Motion ?q1 ?q2 ?t) (Traj ?t) (Item ?i) (AtStore ?i)
               (Holding ?i) (HandEmpty) (Served ?i) (Store ?q) (Counter ?q)
               (BarrierAt ?g) (Other ?g1 ?g2) (Checked ?t))
  (:action move
    :parameters (?q1 ?q2 ?t)
    :precondition (and (Motion ?q1 ?q2 ?t) (AtConf ?q1) CHECK)
    :effect (and (AtConf ?q2) (not (AtConf ?q1))))
  (:action pick
    :parameters (?i ?q)
    :precondition (and (Item ?i) (AtStore ?i) (Store ?q) (AtConf ?q) (HandEmpty))
    :effect (and (Holding ?i) (not (AtStore ?i)) (not (HandEmpty))))
  (:action serve
    :parameters (?i ?q ?g1 ?g2)
    :precondition (and (Holding ?i) (Counter ?q) (AtConf ?q) (BarrierAt ?g1) (Other ?g1 ?g2))
    :effect (and (Served ?i) (HandEmpty) (not (Holding ?i))
                 (BarrierAt ?g2) (not (BarrierAt ?g1)))))
"""

STREAMS = """
(define (stream courier)
  (:stream plan-motion
    :inputs (?q1 ?q2) :domain (and (Conf ?q1) (Conf ?q2))
    :fluents (BarrierAt)
    :outputs (?t) :certified (and (Traj ?t) (Motion ?q1 ?q2 ?t)))
  CHECK)
"""
# With ``checked``, a drive also needs a (state-free) test of its route: the test of the
# second drive's route must be a call of its own too.
CHECK_STREAM = """(:stream check-route
    :inputs (?t) :domain (Traj ?t) :certified (Checked ?t))"""

STORE = (0.0, 0.0)
COUNTER = (10.0, 0.0)
GAPS = {"north": (5.0, 4.0), "south": (5.0, -4.0)}


def plan_motion(q1: tuple[float, float], q2: tuple[float, float],
                fluents: Sequence[tuple[Any, ...]] = ()) -> tuple[tuple[Any, ...]] | None:
    """A route from ``q1`` to ``q2`` through the first gap without the barrier."""
    blocked = {fact[1] for fact in fluents if fact[0].lower() == "barrierat"}
    for gap in ("north", "south"):
        if gap not in blocked:
            return (("route", tuple(q1), gap, tuple(q2)),)
    return None


def check_route(route: tuple[Any, ...]) -> bool:
    return route[0] == "route" and route[2] in GAPS


def courier_problem(folder: Path, checked: bool = False) -> PDDLProblem:
    domain = DOMAIN.replace("CHECK", "(Checked ?t)" if checked else "")
    streams = STREAMS.replace("CHECK", CHECK_STREAM if checked else "")
    (folder / "domain.pddl").write_text(textwrap.dedent(domain).lstrip())
    (folder / "stream.pddl").write_text(textwrap.dedent(streams).lstrip())
    init = [("Conf", STORE), ("Conf", COUNTER), ("AtConf", STORE), ("Store", STORE),
            ("Counter", COUNTER), ("HandEmpty",), ("BarrierAt", "south"),
            ("Other", "south", "north"), ("Other", "north", "south")]
    for item in ("parcel1", "parcel2"):
        init += [("Item", item), ("AtStore", item)]
    goal = ("and", ("Served", "parcel1"), ("Served", "parcel2"))
    return PDDLProblem(read(folder / "domain.pddl"), {}, read(folder / "stream.pddl"),
                       {"plan-motion": from_fn(plan_motion),
                        "check-route": from_test(check_route)}, init, goal)


def replay(steps: Sequence[Any]) -> None:
    """Raise ``AssertionError`` unless the plan, run on the Python values, serves both
    items and never drives through the gap the barrier stands in."""
    at, barrier, holding, served = STORE, "south", None, set()
    for step in steps:
        name, args = step.name, step.args
        if name == "move":
            q1, q2, route = args
            assert tuple(q1) == at, (q1, at)
            assert route[0] == "route" and route[1] == tuple(q1) and route[3] == tuple(q2)
            assert route[2] != barrier, f"drove through the {barrier} gap's barrier"
            at = tuple(q2)
        elif name == "pick":
            assert at == STORE and holding is None and args[0] not in served
            holding = args[0]
        elif name == "serve":
            assert at == COUNTER and holding == args[0] and args[2] == barrier
            served.add(holding)
            holding, barrier = None, args[3]
    assert served == {"parcel1", "parcel2"}


@pytest.mark.parametrize("checked", [False, True])
@pytest.mark.parametrize("algorithm", ["adaptive", "binding", "focused"])
def test_the_same_motion_in_two_states_gets_two_calls(tmp_path: Path, algorithm: str,
                                                       checked: bool) -> None:
    problem = courier_problem(tmp_path, checked)
    solution = solve(problem, algorithm=algorithm, max_time=20, verbose=False)
    assert solution.plan is not None, algorithm
    replay(solution.plan)
    drives = [step.args[2] for step in solution.plan if step.name == "move"]
    assert [route[2] for route in drives] == ["north", "south", "south"]


@pytest.mark.parametrize("checked", [False, True])
@pytest.mark.parametrize("algorithm", ["adaptive", "binding", "focused"])
def test_the_first_bound_skeleton_is_the_plan(tmp_path: Path, algorithm: str,
                                             checked: bool) -> None:
    """Nothing fails: the first optimistic search gives the skeleton, whose binding calls
    the motion once per state it is driven in (store -> counter in two states, counter ->
    store in one: 3 calls, all succeed), and the bound plan is a plan over the real facts:
    two searches in all (before, the second drive reused the first state's route: 5-7
    searches, one of them a failed search over the real facts)."""
    planning_problem = to_planning_problem(courier_problem(tmp_path, checked), None)
    result = plan(planning_problem, PlannerConfig(algorithm=algorithm, max_time=20))
    assert result.solved
    motion = result.stats["streams"]["plan-motion"]
    assert motion["calls"] == 3 and motion["successes"] == 3, motion
    if checked:  # each route tested once (the two store -> counter routes differ)
        test = result.stats["streams"]["check-route"]
        assert test["calls"] == 3 and test["successes"] == 3, test
    # With the route test, a first search at complexity 0 (no test of an optimistic
    # route yet) finds no plan.
    assert result.stats["searches"] == (3 if checked else 2), result.stats
