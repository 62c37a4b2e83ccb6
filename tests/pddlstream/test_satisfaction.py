"""PDDLStream-style constraint satisfaction, several ``increase`` effects in one action, and
stream-file functions used by actions (PDDLStream's ``advanced/multi_cost`` shape)."""

from __future__ import annotations

import itertools
import math
import random

import pytest

from ltamp_cli.pddlstream import (
    FunctionInfo,
    InputError,
    Minimize,
    PDDLProblem,
    SatisfactionProblem,
    add_opt_function,
    constraint_satisfaction,
    from_gen_fn,
    from_test,
    is_parameter,
    solve,
    solve_pddlstream_satisfaction,
)

GRID_STREAM = """
(define (stream grid)
  (:stream sample-cell :outputs (?c) :certified (and (Cell ?c)))
  (:stream test-adjacent :inputs (?c1 ?c2) :domain (and (Cell ?c1) (Cell ?c2))
    :certified (Adjacent ?c1 ?c2))
  (:stream test-free :inputs (?c) :domain (Cell ?c) :certified (Free ?c))
  (:function (Manhattan ?c1 ?c2) (and (Cell ?c1) (Cell ?c2))))
"""
WALL = {(0, 0), (1, 1), (2, 1), (1, 2)}  # the start cell (0, 0) is not free


def grid_map(seed: int, cells: int = 40) -> dict[str, object]:
    rng = random.Random(seed)

    def sample() -> object:
        for _ in range(cells):
            yield ((rng.randrange(4), rng.randrange(4)),)

    return {
        "sample-cell": from_gen_fn(sample),
        "test-adjacent": from_test(lambda a, b: abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1),
        "test-free": from_test(lambda c: c not in WALL),
        "manhattan": lambda a, b: float(abs(a[0] - b[0]) + abs(a[1] - b[1])),
    }


@pytest.mark.parametrize("seed", range(4))
def test_first_assignment_satisfies_every_constraint(seed: int) -> None:
    start = (0, 0)
    problem = SatisfactionProblem(
        GRID_STREAM, grid_map(seed), [("Cell", start)],
        [("Adjacent", start, "?a"), ("Free", "?a"), ("Adjacent", "?a", "?b"), ("Free", "?b"),
         ("Adjacent", "?b", "?c"), ("Free", "?c")])
    solution = constraint_satisfaction(problem, max_time=20, verbose=False)
    assert solution.bindings is not None
    a, b, c = (solution.bindings[p] for p in ("?a", "?b", "?c"))
    path = [start, a, b, c]
    for here, there in itertools.pairwise(path):
        assert abs(here[0] - there[0]) + abs(here[1] - there[1]) == 1
    assert not set(path[1:]) & WALL
    assert solution.cost == 0.0  # no objectives
    assert ("cell", a) in solution.facts  # predicate names are lower-cased


def test_minimize_finds_the_optimum() -> None:
    """Two adjacent free cells among five: (0,1)-(0,2) costs 1 + 1 from the start and
    (0,2)-(0,1) costs 2 + 1; no other pair is adjacent and free."""
    start = (0, 0)
    cells = [((0, 1),), ((3, 3),), ((0, 2),), ((1, 0),), ((2, 2),)]
    stream_map = grid_map(0)
    stream_map["sample-cell"] = from_gen_fn(lambda: iter(cells))
    problem = SatisfactionProblem(
        GRID_STREAM, stream_map, [("Cell", start)],
        [("Free", "?a"), ("Free", "?b"), Minimize(("Manhattan", start, "?a")),
         Minimize(("Manhattan", "?a", "?b")), ("Adjacent", "?a", "?b")])
    solution = constraint_satisfaction(problem, success_cost=0, max_time=20, verbose=False)
    assert solution.bindings == {"?a": (0, 1), "?b": (0, 2)}
    assert solution.cost == 2.0
    unweighted = constraint_satisfaction(problem, costs=False, max_time=20, verbose=False)
    assert unweighted.bindings is not None and unweighted.cost == 0.0


def test_unsatisfiable_problem_has_no_bindings() -> None:
    stream_map = grid_map(0)
    stream_map["sample-cell"] = from_gen_fn(lambda: iter([((1, 1),), ((2, 1),)]))
    problem = SatisfactionProblem(GRID_STREAM, stream_map, [],
                                  [("Cell", "?a"), ("Free", "?a")])
    solution = solve_pddlstream_satisfaction(problem, incremental=True, max_time=20,
                                             verbose=False)
    assert solution.bindings is None
    assert math.isinf(solution.cost)


@pytest.mark.parametrize("terms, message", [
    ([], "no terms"),
    ([(3, "?a")], "satisfaction term 0: expected a predicate or function name"),
    (["Cell"], "satisfaction term 0: expected a fact tuple"),
])
def test_bad_terms_are_one_line_errors(terms: list[object], message: str) -> None:
    with pytest.raises(InputError, match=message) as raised:
        constraint_satisfaction(SatisfactionProblem(GRID_STREAM, grid_map(0), [], terms),
                                verbose=False)
    assert "\n" not in str(raised.value)


def test_bindings_keep_the_parameters_spelling() -> None:
    problem = SatisfactionProblem(GRID_STREAM, grid_map(1), [("Cell", (0, 1))],
                                  [("Adjacent", "?Next", (0, 1)), ("Free", "?next")])
    solution = constraint_satisfaction(problem, max_time=20, verbose=False)
    assert solution.bindings is not None and list(solution.bindings) == ["?Next"]
    assert solution.bindings["?Next"] not in WALL


def test_is_parameter() -> None:
    assert is_parameter("?x") and not is_parameter("x") and not is_parameter(("?x",))


COST_DOMAIN = """
(define (domain toll)
  (:requirements :strips :action-costs)
  (:predicates (Road ?r) (Done))
  (:action drive :parameters (?r)
    :precondition (Road ?r)
    :effect (and (Done) (increase (total-cost) 2) (increase (total-cost) (Toll ?r))
                 (increase (total-cost) (Fuel ?r)))))
"""
COST_STREAM = """
(define (stream toll)
  (:function (Toll ?r) (Road ?r))
  (:function (Fuel ?r) (Road ?r)))
"""


def test_several_increases_sum_and_stream_functions_need_no_declaration() -> None:
    """The domain declares no :functions: both come from the stream file (as PDDLStream's
    translator accepts), and the action's three increases add up."""
    stream_map: dict[str, object] = {"Fuel": lambda r: {"north": 1.0, "south": 4.0}[r]}
    stream_info: dict[str, object] = {}
    add_opt_function("Toll", lambda r: {"north": 6.0, "south": 0.5}[r], stream_map,
                     stream_info, constant=1.0, coefficient=2.0)
    assert isinstance(stream_info["Toll"], FunctionInfo)
    problem = PDDLProblem(COST_DOMAIN, {}, COST_STREAM, stream_map,
                          [("Road", "north"), ("Road", "south")], ("Done",))
    solution = solve(problem, stream_info=stream_info, success_cost=0, max_time=20,
                     verbose=False)
    # north: 2 + (1 + 2*6) + 1 = 16; south: 2 + (1 + 2*0.5) + 4 = 8.
    assert [(a.name, a.args) for a in solution.plan] == [("drive", ("south",))]
    assert solution.cost == pytest.approx(8.0)


def test_an_undeclared_function_used_without_a_stream_is_still_refused() -> None:
    domain = COST_DOMAIN.replace("(Fuel ?r)))", "(Oil ?r)))")
    problem = PDDLProblem(domain, {}, COST_STREAM, {"Toll": lambda r: 1.0, "Fuel": lambda r: 1.0},
                          [("Road", "north")], ("Done",))
    with pytest.raises(InputError, match="unknown function 'oil'"):
        solve(problem, verbose=False)
