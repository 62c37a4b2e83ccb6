"""The independent validator: accepts correct plans, rejects broken ones with clear errors.

Hand-made problems exercise the evaluator (derived predicates incl. recursive ones,
quantifiers, conditional and universal effects, costs, external predicates); planner
results corrupted on purpose check the replay and the certificate checks.
"""

from __future__ import annotations

import ast
import copy
from collections.abc import Callable
from pathlib import Path

import pytest

from ltamp_cli.planner.problem import PlanningProblem, load_problem
from ltamp_cli.planner.result import Certificate, PlanResult, PlanStep, StreamResult
from ltamp_cli.planner.validate import validate_plan

MakeProblem = Callable[..., Path]

GRAPH_DOMAIN = """
(define (domain graph)
  (:requirements :typing :derived-predicates :conditional-effects :equality)
  (:types node item)
  (:predicates (Edge ?a - node ?b - node) (At ?n - node) (Carried ?i - item)
               (Lit ?n - node) (Reach ?a - node ?b - node) (Dark ?n - node)
               (ItemAt ?i - item ?n - node) (Visited ?n - node))
  (:functions (Len ?a ?b) (total-cost))
  ; recursive: transitive closure of Edge
  (:derived (Reach ?a - node ?b - node)
    (or (Edge ?a ?b) (exists (?c - node) (and (Edge ?a ?c) (Reach ?c ?b)))))
  ; negation of a lower stratum
  (:derived (Dark ?n - node) (not (Lit ?n)))
  (:action go
    :parameters (?a - node ?b - node)
    :precondition (and (At ?a) (Reach ?a ?b) (not (= ?a ?b)) (not (Dark ?b)))
    :effect (and (At ?b) (not (At ?a)) (Visited ?b)
                 (forall (?i - item) (when (Carried ?i)
                                           (and (ItemAt ?i ?b) (not (ItemAt ?i ?a)))))
                 (increase (total-cost) (Len ?a ?b))))
  (:action grab
    :parameters (?i - item ?n - node)
    :precondition (and (At ?n) (ItemAt ?i ?n)
                       (imply (Visited ?n) (exists (?m - node) (Edge ?m ?n))))
    :effect (and (Carried ?i) (increase (total-cost) 1)))
  (:action light-all
    :parameters ()
    :precondition (forall (?i - item) (Carried ?i))
    :effect (and (forall (?n - node) (Lit ?n)) (increase (total-cost) 2))))
"""
GRAPH_PROBLEM = """
domain: dom
objects:
  n1: {type: node}
  n2: {type: node}
  n3: {type: node}
  n4: {type: node}
  key: {type: item}
init:
  - (Edge n1 n2)
  - (Edge n2 n3)
  - (Edge n3 n4)
  - (At n1)
  - (ItemAt key n1)
  - (Lit n1)
  - (Lit n3)
  - (= (Len n1 n3) 5)
  - (= (Len n3 n4) 2.5)
goal: (and (At n4) (ItemAt key n4) (forall (?n - node) (imply (Visited ?n) (Lit ?n))))
"""


def test_validator_is_independent_of_the_search() -> None:
    import ltamp_cli.planner.validate as module

    tree = ast.parse(Path(module.__file__).read_text())
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    imported |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                 for alias in node.names}
    planner = {name for name in imported if name and name.startswith("ltamp_cli")}
    assert planner <= {"ltamp_cli.planner.pddl.syntax", "ltamp_cli.planner.problem",
                       "ltamp_cli.planner.result"}, planner


def step(name: str, *args: str, cost: float = 0.0) -> PlanStep:
    return PlanStep(name, args, args, cost)


def plan_result(steps: list[PlanStep], results: list[StreamResult] | None = None,
                objects: dict[str, object] | None = None) -> PlanResult:
    cost = sum(s.cost for s in steps)
    return PlanResult("solved", steps, cost, 0.0, {},
                      Certificate(stream_results=list(results or [])), dict(objects or {}))


@pytest.fixture
def graph(make_problem: MakeProblem) -> PlanningProblem:
    return load_problem(make_problem(GRAPH_DOMAIN, GRAPH_PROBLEM))


GOOD_GRAPH_PLAN = [step("grab", "key", "n1", cost=1), step("go", "n1", "n3", cost=5),
                   step("light-all", cost=2), step("go", "n3", "n4", cost=2.5)]


def test_valid_plan_with_recursive_derived_and_conditional_effects(graph: PlanningProblem
                                                                   ) -> None:
    report = validate_plan(graph, plan_result(GOOD_GRAPH_PLAN))
    assert report.valid, report.errors
    assert report.cost == pytest.approx(10.5)
    assert ("itemat", "key", "n4") in report.final_state
    assert ("itemat", "key", "n1") not in report.final_state  # conditional delete applied
    assert {("lit", n) for n in ("n1", "n2", "n3", "n4")} <= report.final_state


def test_negated_derived_precondition_fails(graph: PlanningProblem) -> None:
    # n4 is dark until light-all: (not (Dark n4)) fails.
    plan = [step("grab", "key", "n1", cost=1), step("go", "n1", "n4", cost=0)]
    report = validate_plan(graph, plan_result(plan))
    assert not report.valid
    assert report.errors[0].startswith("step 2 (go n1 n4): precondition does not hold")
    assert "(not (dark n4))" in report.errors[0]


def test_recursive_reach_is_directional(graph: PlanningProblem) -> None:
    # No edges lead back to n1: (Reach n3 n1) is false.
    plan = [step("grab", "key", "n1", cost=1), step("go", "n1", "n3", cost=5),
            step("go", "n3", "n1", cost=0)]
    report = validate_plan(graph, plan_result(plan))
    assert not report.valid and "(reach n3 n1)" in report.errors[0]


def test_universal_precondition_and_goal_quantifier(graph: PlanningProblem) -> None:
    # light-all needs every item carried.
    report = validate_plan(graph, plan_result([step("light-all", cost=2)]))
    assert not report.valid and "step 1 (light-all)" in report.errors[0]
    # Without light-all n4 stays dark: the plan stops short of the goal.
    plan = [step("grab", "key", "n1", cost=1), step("go", "n1", "n3", cost=5)]
    report = validate_plan(graph, plan_result(plan))
    assert not report.valid
    assert report.errors[-1].startswith("goal: does not hold")
    assert "(at n4)" in report.errors[-1] and "(forall" not in report.errors[-1]


def test_costs_are_recomputed(graph: PlanningProblem) -> None:
    plan = [*GOOD_GRAPH_PLAN[:1], step("go", "n1", "n3", cost=4), *GOOD_GRAPH_PLAN[2:]]
    report = validate_plan(graph, plan_result(plan))
    assert not report.valid
    assert any("step 2 (go n1 n3): reported cost 4 but the action costs 5" in e
               for e in report.errors)
    assert any(e.startswith("plan cost: reported 9.5") for e in report.errors)


def test_bad_steps(graph: PlanningProblem) -> None:
    cases = {
        "fly": "no action 'fly'",
        "go-arity": "takes 2 argument(s), got 1",
        "go-type": "'key' is not of type 'node'",
        "go-unknown": "unknown object 'n9'",
    }
    plans = {
        "fly": [step("fly", "n1")],
        "go-arity": [step("go", "n1")],
        "go-type": [step("go", "n1", "key")],
        "go-unknown": [step("go", "n1", "n9")],
    }
    for key, fragment in cases.items():
        report = validate_plan(graph, plan_result(plans[key]))
        assert not report.valid and fragment in report.errors[0], (key, report.errors)


def test_missing_cost_value_is_reported(graph: PlanningProblem) -> None:
    # (Len n1 n2) has no value.
    plan = [step("grab", "key", "n1", cost=1), step("light-all", cost=2), step("go", "n1", "n2")]
    report = validate_plan(graph, plan_result(plan))
    assert not report.valid
    assert report.errors[0].startswith("step 3 (go n1 n2): cost term (len n1 n2) has no value")


STREAM_DOMAIN = """
(define (domain line)
  (:predicates (Pos ?p) (At ?p) (Step ?p ?q) (Safe ?p) (Hot ?p))
  (:functions (Dist ?p ?q))
  (:action move
    :parameters (?p ?q)
    :precondition (and (At ?p) (Step ?p ?q) (Safe ?q) (not (Hot ?q)))
    :effect (and (At ?q) (not (At ?p)) (increase (total-cost) (Dist ?p ?q)))))
"""
STREAM_FILE = """
(define (stream line)
  (:stream next
    :inputs (?p)
    :domain (Pos ?p)
    :outputs (?q)
    :certified (and (Pos ?q) (Step ?p ?q)))
  (:stream test-safe
    :inputs (?p)
    :domain (Pos ?p)
    :certified (Safe ?p))
  (:function (Dist ?p ?q) (and (Pos ?p) (Pos ?q)))
  (:predicate (Hot ?p) (Pos ?p)))
"""
STREAM_BINDINGS = """
def make_streams(world, rng):
    def next_(p):
        yield (p + 1.0,)
    return {"next": next_, "test-safe": lambda p: p < world["limit"],
            "dist": lambda p, q: abs(q - p) * 2.0, "hot": lambda p: p == world["hot"]}
"""
STREAM_PROBLEM = """
domain: dom
bindings: bindings.py
world: {limit: 2.5, hot: 3.0}
objects: {p0: 0.0}
init: ["(Pos p0)", "(At p0)"]
goal: (exists (?p) (and (At ?p) (Step p0 ?p)))
"""


@pytest.fixture
def line(make_problem: MakeProblem) -> PlanningProblem:
    return load_problem(make_problem(STREAM_DOMAIN, STREAM_PROBLEM, STREAM_FILE,
                                     STREAM_BINDINGS))


NEXT = StreamResult("next", ("p0",), ("@q0",), (("pos", "@q0"), ("step", "p0", "@q0")))
SAFE = StreamResult("test-safe", ("@q0",), (), (("safe", "@q0"),))


def test_stream_certificate_accepted(line: PlanningProblem) -> None:
    result = plan_result([PlanStep("move", ("p0", "@q0"), (0.0, 1.0), 2.0)], [SAFE, NEXT],
                         {"p0": 0.0, "@q0": 1.0})
    report = validate_plan(line, result)
    assert report.valid, report.errors
    assert report.cost == 2.0  # from the :function binding


@pytest.mark.parametrize(("results", "fragment"), [
    ([SAFE], "domain fact (pos @q0) is neither initial nor certified"),
    ([NEXT], "precondition does not hold; failing: (safe @q0)"),
    ([NEXT, StreamResult("test-safe", ("@q0",), (), (("safe", "@q0"), ("pos", "p0")))],
     "certifies (pos p0) which is not declared"),
    ([NEXT, StreamResult("test-safe", ("@q0",), (), ())], "does not certify (safe @q0)"),
    ([NEXT, SAFE, StreamResult("teleport", ("p0",), (), (("at", "@q0"),))],
     "no such stream"),
    ([NEXT, StreamResult("test-safe", ("@q0", "p0"), (), (("safe", "@q0"),))],
     "expected 1 input(s), got 2"),
])
def test_bad_certificates_rejected(line: PlanningProblem, results: list[StreamResult],
                                   fragment: str) -> None:
    result = plan_result([PlanStep("move", ("p0", "@q0"), (0.0, 1.0), 2.0)], results,
                         {"p0": 0.0, "@q0": 1.0})
    report = validate_plan(line, result)
    assert not report.valid
    assert any(fragment in error for error in report.errors), report.errors


def test_test_stream_is_re_evaluated(line: PlanningProblem) -> None:
    # 3.0 is not below the limit 2.5: a certificate claiming (Safe @q0) is a lie.
    objects = {"p0": 0.0, "@q0": 3.0}
    result = plan_result([PlanStep("move", ("p0", "@q0"), (0.0, 3.0), 6.0)], [NEXT, SAFE],
                         objects)
    report = validate_plan(line, result)
    assert not report.valid
    assert "test-safe(@q0): its Python binding returns false" in report.errors[0]


def test_external_predicate_is_evaluated(line: PlanningProblem) -> None:
    # With a limit of 5 the pose 3.0 is safe but hot: (not (Hot @q0)) fails.
    line.world = {"limit": 5.0, "hot": 3.0}
    result = plan_result([PlanStep("move", ("p0", "@q0"), (0.0, 3.0), 6.0)], [NEXT, SAFE],
                         {"p0": 0.0, "@q0": 3.0})
    report = validate_plan(line, result)
    # (not (Hot ?q)) needs the predicate's answer "false": the negated predicate ~hot
    # (ltamp_cli/planner/pddl/negation.py)
    assert not report.valid and "(~hot @q0)" in report.errors[0]


def test_values_must_match_objects(line: PlanningProblem) -> None:
    result = plan_result([PlanStep("move", ("p0", "@q0"), (0.0, 1.5), 2.0)], [NEXT, SAFE],
                         {"p0": 0.0, "@q0": 1.0})
    report = validate_plan(line, result)
    assert not report.valid and "the value given for '@q0'" in report.errors[0]


def test_no_plan_is_invalid(line: PlanningProblem) -> None:
    result = PlanResult("infeasible", None, float("inf"), 0.0, {}, Certificate())
    report = validate_plan(line, result)
    assert not report.valid and "no plan" in report.errors[0]


# --- planner results, corrupted -------------------------------------------------------------
def _corrupt(result: PlanResult, plan: list[PlanStep]) -> PlanResult:
    broken = copy.copy(result)
    broken.plan = plan
    broken.cost = sum(s.cost for s in plan)
    return broken


@pytest.mark.parametrize("name", ["tamp2d_blocked", "blocksworld"])
def test_planner_plans_corrupted(solved, name: str) -> None:  # type: ignore[no-untyped-def]
    problem = solved.problem(name)
    result = solved.result(name, "incremental")
    assert result.solved
    assert validate_plan(problem, result, check_stream_domains=False).valid
    plan = list(result.plan)

    dropped = _corrupt(result, plan[:1] + plan[2:])  # drop the second step
    report = validate_plan(problem, dropped, check_stream_domains=False)
    assert not report.valid and report.errors[0].startswith("step ")

    # Swap the arguments of the first step with two distinct arguments.
    index = next(i for i, s in enumerate(plan) if len(set(s.args)) >= 2)
    first = plan[index]
    args = (first.args[1], first.args[0], *first.args[2:])
    values = (first.values[1], first.values[0], *first.values[2:])
    swapped = _corrupt(result, [*plan[:index], PlanStep(first.name, args, values, first.cost),
                                *plan[index + 1:]])
    report = validate_plan(problem, swapped, check_stream_domains=False)
    assert not report.valid and report.errors[0].startswith(f"step {index + 1} ")

    truncated = _corrupt(result, plan[:-1])
    report = validate_plan(problem, truncated, check_stream_domains=False)
    assert not report.valid and report.errors[-1].startswith("goal: does not hold")

    reordered = _corrupt(result, [plan[1], plan[0], *plan[2:]])
    assert not validate_plan(problem, reordered, check_stream_domains=False).valid


def test_planner_certificate_corrupted(solved) -> None:  # type: ignore[no-untyped-def]
    problem = solved.problem("tamp2d_blocked")
    result = solved.result("tamp2d_blocked", "incremental")
    results = result.certificate.stream_results
    # Every stream result the plan relies on is needed: dropping any kind breaks the replay.
    for kind in ("inverse-kinematics", "plan-motion", "test-cfree", "sample-pose"):
        kept = [r for r in results if r.stream != kind]
        assert len(kept) < len(results), kind
        broken = copy.copy(result)
        broken.certificate = Certificate(result.certificate.preimage, kept,
                                         result.certificate.facts)
        report = validate_plan(problem, broken, check_stream_domains=False)
        assert not report.valid, kind
    # A collision test claimed for two overlapping poses is caught by re-running it.
    fake = StreamResult("test-cfree", ("a", "pa", "b", "pa"), (),
                        (("cfree", "a", "pa", "b", "pa"),))
    broken = copy.copy(result)
    broken.certificate = Certificate(result.certificate.preimage, [*results, fake],
                                     result.certificate.facts)
    report = validate_plan(problem, broken, check_stream_domains=False)
    assert not report.valid
    assert any("test-cfree(a pa b pa): its Python binding returns false" in e
               for e in report.errors)
