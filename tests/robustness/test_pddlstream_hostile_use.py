"""Round 3: the drop-in PDDLStream API used the way PDDLStream scripts use it.

Bugs this file caught (each failed before its fix):

* numbers equal in Python but of different types (``np.float64(2.0)`` from a numpy
  computation and the literal ``2.0`` in the goal, ``1`` and ``1.0``) were different objects,
  so a goal over a stream's numpy output was answered "no plan" (PDDLStream keys hashable
  values by equality: one object);
* ``solve`` ignored every keyword it did not know: a misspelt ``max_tme=1`` ran without
  limit, ``initial_complexity=`` / ``max_complexity=`` were dropped;
* ``verbose=True`` printed the planner's cost (0) where the returned ``Solution`` had the
  unit cost (1).
"""

from __future__ import annotations

import importlib
import math
from typing import Any

import numpy as np
import pytest

from ltamp_cli.pddlstream import (
    INF,
    InputError,
    PDDLProblem,
    from_fn,
    from_gen_fn,
    from_test,
    solve,
)

DOMAIN = """
(define (domain place)
  (:requirements :strips)
  (:predicates (Block ?b) (Pose ?b ?p) (AtPose ?b ?p) (Placed ?b) (Goal ?p))
  (:action place
    :parameters (?b ?p)
    :precondition (and (Block ?b) (Pose ?b ?p))
    :effect (and (AtPose ?b ?p) (Placed ?b))))
"""
STREAM = """
(define (stream place)
  (:stream sample-pose
    :inputs (?b) :domain (Block ?b)
    :outputs (?p) :certified (Pose ?b ?p))
  (:stream test-goal :inputs (?b ?p) :domain (Pose ?b ?p) :certified (Goal ?p)))
"""


def place_problem(sample: Any, goal: Any, init: Any = (("Block", "a"),),
                  test: Any = None) -> PDDLProblem:
    stream_map = {"sample-pose": sample,
                  "test-goal": test or from_test(lambda b, p: True)}
    return PDDLProblem(DOMAIN, {}, STREAM, stream_map, list(init), goal)


@pytest.mark.parametrize("made, wanted", [
    (np.float64(2.0), 2.0), (2.0, np.float64(2.0)), (np.int64(2), 2), (2, 2.0),
    (np.float32(0.5), 0.5), ((np.float64(1.0), 2), (1.0, 2.0)),
])
def test_equal_numbers_are_one_object(made: Any, wanted: Any) -> None:
    """A stream yields ``made``; the goal names ``wanted`` (equal in Python). Incremental:
    the optimistic algorithms, as PDDLStream's, never equate a stream's placeholder output
    with a constant of the goal."""
    problem = place_problem(from_fn(lambda b: (made,)), ("AtPose", "a", wanted))
    solution = solve(problem, algorithm="incremental", max_time=10, verbose=False)
    assert solution.plan is not None and len(solution.plan) == 1
    assert solution.plan[0].args[1] == wanted


@pytest.mark.parametrize("algorithm", ["adaptive", "binding", "focused", "incremental"])
def test_equal_numbers_in_init_and_goal(algorithm: str) -> None:
    problem = place_problem(from_fn(lambda b: (0.0,)), ("Placed", 3.0),
                            init=[("Block", np.float64(3.0))])
    solution = solve(problem, algorithm=algorithm, max_time=10, verbose=False)
    assert solution.plan is not None and solution.plan[0].args[0] == 3.0


def test_unequal_numbers_stay_apart() -> None:
    """The fix keys numbers by value: 2.0 and 2.5 are still two objects (no plan puts the
    block at 2.5 when the stream only makes 2.0)."""
    problem = place_problem(from_fn(lambda b: (np.float64(2.0),)), ("AtPose", "a", 2.5))
    assert solve(problem, algorithm="incremental", max_time=5, verbose=False).plan is None


@pytest.mark.parametrize("option", ["max_tme", "stream_infos", "algoritm", "maxtime"])
def test_misspelt_option_is_refused_in_one_line(option: str) -> None:
    problem = place_problem(from_fn(lambda b: (1.0,)), ("Placed", "a"))
    with pytest.raises(InputError, match=f"'{option}'") as error:
        solve(problem, verbose=False, **{option: 1})
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("options", [
    {"planner": "ff-astar"}, {"max_planner_time": 10}, {"search_sample_ratio": 2},
    {"unit_efforts": True}, {"max_skeletons": None}, {"max_skeletons": 3}, {"debug": True},
    {"visualize": False}, {"max_iterations": 100}, {"max_memory": INF},
    {"effort_weight": 1}, {"max_failures": 0}, {"complexity_step": 1}, {"reorder": False},
    {"replan_actions": set()}, {"max_effort": INF}, {"max_cost": INF}, {"clean": False},
])
def test_pddlstream_options_are_accepted(options: dict[str, Any]) -> None:
    problem = place_problem(from_fn(lambda b: (1.0,)), ("Placed", "a"))
    solution = solve(problem, max_time=10, verbose=False, **options)
    assert solution.plan is not None and solution.cost == 1.0


def layered_problem() -> PDDLProblem:
    """The goal needs a value two stream calls deep (complexity 2)."""
    domain = """
    (define (domain deep) (:requirements :strips)
      (:predicates (Seed ?x) (One ?x) (Two ?x) (Done))
      (:action finish :parameters (?x) :precondition (Two ?x) :effect (Done)))
    """
    streams = """
    (define (stream deep)
      (:stream one :inputs (?x) :domain (Seed ?x) :outputs (?y) :certified (One ?y))
      (:stream two :inputs (?x) :domain (One ?x) :outputs (?y) :certified (Two ?y)))
    """
    return PDDLProblem(domain, {}, streams, {"one": from_fn(lambda x: (x + 1,)),
                                             "two": from_fn(lambda x: (x + 1,))},
                       [("Seed", 0)], ("Done",))


@pytest.mark.parametrize("given, initial, maximum", [
    ({"initial_complexity": 2, "max_complexity": 5}, 2, 5),
    ({"max_complexity": INF}, 0, INF), ({"max_complexity": 3.0}, 0, 3), ({}, 0, 20),
])
def test_complexity_options_reach_the_planner(monkeypatch: pytest.MonkeyPatch,
                                              given: dict[str, Any], initial: int,
                                              maximum: float) -> None:
    """They used to be swallowed by ``**ignored`` (the planner ran with 0 and 20)."""
    module = importlib.import_module("ltamp_cli.pddlstream.solve")  # the name is shadowed
    seen: list[Any] = []
    real_plan = module.plan

    def spy(problem: Any, config: Any) -> Any:
        seen.append(config)
        return real_plan(problem, config)

    monkeypatch.setattr(module, "plan", spy)
    solution = solve(layered_problem(), max_time=10, verbose=False, **given)
    assert solution.plan is not None
    assert (seen[0].initial_complexity, seen[0].max_complexity) == (initial, maximum)


@pytest.mark.parametrize("option, value", [
    ("max_complexity", -1), ("max_complexity", 1.5), ("max_complexity", "3"),
    ("initial_complexity", -2), ("initial_complexity", math.nan),
    ("initial_complexity", INF),
])
def test_bad_complexity_is_one_line(option: str, value: Any) -> None:
    problem = place_problem(from_fn(lambda b: (1.0,)), ("Placed", "a"))
    with pytest.raises(InputError, match=option) as error:
        solve(problem, verbose=False, max_time=5, **{option: value})
    assert "\n" not in str(error.value)


def test_initial_complexity_is_accepted() -> None:
    solution = solve(layered_problem(), initial_complexity=2, max_time=10, verbose=False)
    assert solution.plan is not None


def test_verbose_line_gives_the_solution_cost(capsys: pytest.CaptureFixture[str]) -> None:
    """No action costs: PDDLStream counts each action as 1, and so does the printed line."""
    problem = place_problem(from_fn(lambda b: (1.0,)), ("Placed", "a"))
    solution = solve(problem, max_time=10, verbose=True)
    assert solution.cost == 1.0
    assert "cost 1" in capsys.readouterr().out


def test_generator_yielding_wrong_arity_is_one_line() -> None:
    problem = place_problem(from_gen_fn(lambda b: iter([(1.0, 2.0)])), ("Placed", "a"))
    with pytest.raises(InputError, match=r"sample-pose.*1 value") as error:
        solve(problem, max_time=5, verbose=False)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("raw", [lambda b: (1.0,), lambda b: 5, lambda b: "ab",
                                 lambda b: iter([3.0])])
def test_unwrapped_procedure_is_one_line_with_a_hint(raw: Any) -> None:
    """A procedure not wrapped by ``from_fn``/``from_gen_fn`` (returning one output tuple, a
    number, a string, or yielding bare values) used to surface as a ``StreamError`` "'float'
    object is not iterable"; now one ``InputError`` naming the stream and the wrapper."""
    problem = place_problem(raw, ("Placed", "a"))
    with pytest.raises(InputError, match=r"sample-pose.*from_fn") as error:
        solve(problem, max_time=5, verbose=False)
    assert "\n" not in str(error.value)


def test_raw_procedure_yielding_output_lists_still_works() -> None:
    """A hand-written list generator (PDDLStream's ``from_list_gen_fn`` shape) is fine."""
    problem = place_problem(lambda b: iter([[(1.0,)], [], [(2.0,), [3.0]]]), ("Placed", "a"))
    assert solve(problem, max_time=10, verbose=False).plan is not None
