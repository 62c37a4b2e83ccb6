"""The merge-safe relaxation (:mod:`ltamp_cli.planner.algorithms.multiplicity`) must cover
every real plan, or an optimistic "infeasible" it confirms is wrong (red-team round 8).

* Objects are values: two *instances* of one stream can make the same new value. With one
  abstract output per instance, the facts both instances certify about that value never met
  on one object: ``grasp(o1)`` yields top, side and ``grasp(o2)`` front, side; the goal needs
  one grasp of both; adaptive, binding and focused answered "infeasible" (incremental:
  ``both(side)``).
* A ``:fluents`` stream's instance exhausted in one state (no path while nothing is held)
  was taken as exhausted in every state by the relaxation, which then confirmed the
  optimistic algorithms' "infeasible" for pick-the-key-then-move. The optimistic algorithms
  still do not find that plan (they never plan ``pick`` before the failed ``path``: a
  search limit, left to the planner owners); the answer is now an honest "timeout" that says
  why, not "infeasible".
"""

from __future__ import annotations

import pytest
from conftest import ALGORITHMS, MakeProblem

from ltamp_cli.planner.algorithms.common import PlannerConfig, initial_state
from ltamp_cli.planner.algorithms.multiplicity import relaxed_goal_reachable
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

GRASP_DOMAIN = """
(define (domain grasps)
  (:constants o1 o2)
  (:predicates (Obj ?o) (Grasp ?o ?g) (Done))
  (:action both :parameters (?g) :precondition (and (Grasp o1 ?g) (Grasp o2 ?g))
    :effect (Done)))
"""
GRASP_STREAMS = """
(define (stream grasps)
  (:stream grasp :inputs (?o) :domain (Obj ?o) :outputs (?g) :certified (Grasp ?o ?g)))
"""
GRASP_BINDINGS = """
def make_streams(world, rng):
    def grasp(o):
        for g in world["grasps"][o]:
            yield (g,)
    return {"grasp": grasp}
"""


def grasp_problem(make_problem: MakeProblem, o1: str, o2: str) -> str:
    return make_problem(
        GRASP_DOMAIN,
        f"domain: dom\nbindings: bindings.py\nworld: {{grasps: {{o1: {o1}, o2: {o2}}}}}\n"
        'objects: {o1: o1, o2: o2}\ninit: ["(Obj o1)", "(Obj o2)"]\ngoal: (Done)\n',
        GRASP_STREAMS, GRASP_BINDINGS)


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_two_instances_making_one_new_value(make_problem: MakeProblem,
                                            algorithm: str) -> None:
    """The first calls (the probe's) give top and front; only the second calls of both
    instances make side, a value that did not exist before."""
    problem = load_problem(grasp_problem(make_problem, "[top, side]", "[front, side]"))
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=30))
    assert result.status == "solved", (result.status, result.diagnostics)
    assert [step.values for step in result.plan] == [("side",)]
    assert validate_plan(problem, result).valid


@pytest.mark.parametrize("algorithm", ("adaptive", "focused"))
def test_a_later_output_equal_to_an_earlier_one_of_the_stream(make_problem: MakeProblem,
                                                              algorithm: str) -> None:
    """grasp(o2) is exhausted after side; grasp(o1) makes side on its second call."""
    problem = load_problem(grasp_problem(make_problem, "[top, side]", "[side]"))
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=30))
    assert result.status == "solved", (result.status, result.diagnostics)
    assert [step.values for step in result.plan] == [("side",)]


@pytest.mark.parametrize("algorithm", ("adaptive", "focused"))
def test_no_common_grasp_stays_infeasible(make_problem: MakeProblem, algorithm: str) -> None:
    """Finite generators with no common value: proven infeasible (every instance exhausted,
    by the incremental completion or by the relaxation)."""
    problem = load_problem(grasp_problem(make_problem, "[top, side]", "[front, back]"))
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=30))
    assert result.status == "infeasible"


KEY_DOMAIN = """
(define (domain keys)
  (:predicates (Key ?k) (Holding ?k) (Loc ?a) (At ?a) (Traj ?a ?b ?t))
  (:action pick :parameters (?k) :precondition (Key ?k) :effect (Holding ?k))
  (:action move :parameters (?a ?b ?t) :precondition (and (At ?a) (Traj ?a ?b ?t))
    :effect (and (At ?b) (not (At ?a)))))
"""
KEY_STREAMS = """
(define (stream keys)
  (:stream path :inputs (?a ?b) :domain (and (Loc ?a) (Loc ?b)) :fluents (Holding)
    :outputs (?t) :certified (Traj ?a ?b ?t)))
"""
# The door opens only for a robot that holds a key.
KEY_BINDINGS = """
def make_streams(world, rng):
    def path(a, b, fluents=()):
        if any(fact[0] == "holding" for fact in fluents):
            yield (f"{a}->{b}",)
    return {"path": path}
"""


def test_fluent_instance_exhausted_in_one_state_is_not_exhausted(
        make_problem: MakeProblem) -> None:
    problem = load_problem(make_problem(
        KEY_DOMAIN,
        "domain: dom\nbindings: bindings.py\nobjects: {a: null, b: null, k: null}\n"
        'init: ["(Key k)", "(Loc a)", "(Loc b)", "(At a)"]\ngoal: (At b)\n',
        KEY_STREAMS, KEY_BINDINGS))
    state = initial_state(problem, PlannerConfig())
    instance = state.instance("path", ("a", "b"))  # called holding nothing: no path
    assert state.call(instance) == [] and instance.exhausted
    assert relaxed_goal_reachable(state)
    for algorithm in ("adaptive", "binding", "focused"):
        result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=30))
        assert result.status in ("solved", "timeout"), (algorithm, result.status)
        if result.status == "timeout":
            assert ":fluents" in result.diagnostics["infeasibility_unproven"]
