"""Red-team round 9: the interleaved incremental member and the solve around it.

* ``unit_costs`` with ``success_cost`` (anytime): the first plan's length met the success
  cost, yet the loop compared its action costs and "improved" it into a longer plan (the
  bounded search counted action costs too);
* a ``make_streams`` that refuses a second call (a resource held once per process, such as
  a PyBullet GUI connection): the member's own call failed the whole solve with "make_streams
  failed" after the grace, where the solve without the member went on;
* the incremental completion of an unproven "infeasible" reported ``time_s`` from its own
  start, not the solve's (0.30 s for a 0.64 s solve).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pytest

from ltamp_cli.pddlstream import PDDLProblem, from_fn, solve
from ltamp_cli.pddlstream.problem import to_planning_problem
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve as plan
from ltamp_cli.planner.problem import load_problem

REPO = Path(__file__).resolve().parents[2]
HANDOFF = REPO / "bench" / "problems" / "hidden19" / "hidden_handoff_2.yaml"

ROADS = """(define (domain roads) (:requirements :action-costs)
  (:predicates (At ?x) (Road ?a ?b) (Jet ?a ?b)) (:functions (total-cost))
  (:action drive :parameters (?a ?b) :precondition (and (At ?a) (Road ?a ?b))
    :effect (and (At ?b) (not (At ?a)) (increase (total-cost) 1)))
  (:action fly :parameters (?a ?b) :precondition (and (At ?a) (Jet ?a ?b))
    :effect (and (At ?b) (not (At ?a)) (increase (total-cost) 10))))"""
ROADS_INIT = [("At", "a"), ("Road", "a", "b"), ("Road", "b", "c"), ("Road", "c", "d"),
              ("Jet", "a", "d")]


@pytest.mark.parametrize("algorithm", ["adaptive", "focused", "incremental"])
@pytest.mark.parametrize("success_cost", [0, 1, 3])
def test_unit_cost_anytime_counts_actions(algorithm: str, success_cost: float) -> None:
    """With unit costs, flying (1 action, action cost 10) is the best plan; driving (3
    actions, action cost 3) is worse. Before: flying was found, its action cost 10 exceeded
    the success cost, and the bounded search returned the three drives."""
    problem = PDDLProblem(ROADS, {}, None, {}, ROADS_INIT, ("At", "d"))
    solution = solve(problem, algorithm=algorithm, unit_costs=True,
                     success_cost=success_cost, max_time=20, verbose=False)
    assert [step.name for step in solution.plan] == ["fly"]
    assert solution.cost == 1
    # Without unit costs the action costs decide: the three drives.
    solution = solve(problem, algorithm=algorithm, success_cost=success_cost, max_time=20,
                     verbose=False)
    assert [step.name for step in solution.plan] == ["drive"] * 3


class FastClock:
    """A CPU clock that advances 10 ms per reading: the member's grace passes after a few
    dozen stream calls, whatever the machine's load."""

    def __init__(self, tick: float = 0.01) -> None:
        self.now = 0.0
        self.tick = tick

    def __call__(self) -> float:
        self.now += self.tick
        return self.now


def test_a_make_streams_that_refuses_a_second_call_leaves_the_solve_alone() -> None:
    problem = load_problem(HANDOFF)
    made: list[int] = []
    factory = problem.streams_factory
    assert factory is not None

    def once(world, rng):  # type: ignore[no-untyped-def]
        if made:
            raise RuntimeError("only one GUI connection per process")
        made.append(1)
        return factory(world, rng)

    problem = replace(problem, streams_factory=once)
    result = plan(problem, PlannerConfig(algorithm="adaptive", max_time=3.0,
                                         stream_cpu_clock=FastClock()))
    assert result.status == "timeout"  # handoff_2 needs the member; no error
    assert "only one GUI connection" in result.stats["interleaved"]["skipped"]
    assert made == [1]


WILD = """(define (domain wild) (:predicates (Q ?q) (Goal ?q) (Done))
  (:action finish :parameters (?q) :precondition (and (Q ?q) (Goal ?q)) :effect (Done)))"""
WILD_STREAM = "(define (stream wild) (:stream look :inputs () :domain () :outputs (?q)))"


def test_the_completion_reports_the_solve_time() -> None:
    """A stream without :certified facts (wild): the optimistic "infeasible" proves nothing,
    the incremental completion runs; each of the two calls of ``look`` sleeps 0.3 s."""
    def look() -> tuple[int]:
        time.sleep(0.3)
        return (5,)

    problem = to_planning_problem(PDDLProblem(WILD, {}, WILD_STREAM, {"look": from_fn(look)},
                                              [], ("Done",)))
    result = plan(problem, PlannerConfig(algorithm="adaptive", max_time=30))
    assert result.status == "infeasible"
    assert "wild facts" in result.stats["completed_by"]
    assert result.time_s >= 0.6
    assert result.diagnostics["time_spent"]["total_s"] >= 0.6


PAIRS = """(define (domain pairs) (:predicates (Q ?q) (Pair ?a ?b) (Done))
  (:action finish :parameters (?a ?b) :precondition (and (Q ?a) (Q ?b) (Pair ?a ?b))
    :effect (Done)))"""
PAIRS_STREAM = """(define (stream pairs)
  (:stream sample :inputs () :domain () :outputs (?q) :certified (Q ?q))
  (:stream pair :inputs (?a ?b) :domain (and (Q ?a) (Q ?b)) :certified (Pair ?a ?b)))"""


@pytest.mark.parametrize("algorithm", ["adaptive", "binding", "focused"])
def test_one_iterator_handed_to_both_members_gives_no_wrong_infeasible(algorithm: str) -> None:
    """PDDLStream's ``from_gen(iterator)`` hands the same iterator to every call: the
    optimistic member and the interleaved incremental one split its 12 values: the member
    took 10 and 11, the only pair the test accepts. Before, all three algorithms answered
    "infeasible" (the optimistic ``sample()`` exhausted after 0-9); without the member the
    pair is found. Now an exhausted instance that missed values the same instance made in
    another state of the solve proves nothing (:mod:`.companions`)."""
    from ltamp_cli.pddlstream import from_gen, from_test

    clock = FastClock(tick=1e-3)

    def values() -> Iterator[tuple[int]]:
        for value in range(12):
            clock.now += 0.03  # each value costs 30 ms of (the solve's) CPU
            yield (value,)

    problem = to_planning_problem(PDDLProblem(
        PAIRS, {}, PAIRS_STREAM,
        {"sample": from_gen(values()), "pair": from_test(lambda a, b: a + b == 21)},
        [], ("Done",)))
    result = plan(problem, PlannerConfig(algorithm=algorithm, max_time=20,
                                         stream_cpu_clock=clock))
    # The values are split for good (the member holds 10 and 11, the optimistic member's
    # sample() is spent): an honest timeout, at once, or a plan; never "infeasible".
    assert result.status in ("solved", "timeout"), (result.stats, result.diagnostics)
    if result.status == "solved":
        assert [step.values for step in result.plan] in ([(10, 11)], [(11, 10)])
    else:
        assert "made outputs it never made here" in result.diagnostics[
            "infeasibility_unproven"]


def test_a_completion_whose_make_streams_refuses_is_a_timeout_that_says_why() -> None:
    """The wild-facts problem above with a ``make_streams`` that refuses a second call: the
    completion cannot make its bindings; before, the solve raised "make_streams failed"."""
    problem = to_planning_problem(PDDLProblem(WILD, {}, WILD_STREAM,
                                              {"look": from_fn(lambda: (5,))}, [], ("Done",)))
    factory = problem.streams_factory
    assert factory is not None
    made: list[int] = []

    def once(world, rng):  # type: ignore[no-untyped-def]
        if made:
            raise RuntimeError("only one GUI connection per process")
        made.append(1)
        return factory(world, rng)

    result = plan(replace(problem, streams_factory=once),
                  PlannerConfig(algorithm="adaptive", max_time=30))
    assert result.status == "timeout"
    unproven = result.diagnostics["infeasibility_unproven"]
    assert "wild facts" in unproven and "only one GUI connection" in unproven
