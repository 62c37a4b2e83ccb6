"""Bad input: one-line ``file:line:column: message`` errors at the right place."""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from pathlib import Path

import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem

MakeProblem = Callable[..., Path]  # the make_problem fixture of conftest.py

GOOD_DOMAIN = """
(define (domain d)
  (:predicates (P ?x) (Q ?x ?y))
  (:action go
    :parameters (?x ?y)
    :precondition (and (P ?x) (Q ?x ?y))
    :effect (and (P ?y) (not (P ?x)))))
"""
GOOD_PROBLEM = """
domain: dom
objects: {a: null, b: null}
init: ["(P a)", "(Q a b)"]
goal: (P b)
"""
GOOD_STREAMS = """
(define (stream d)
  (:stream next
    :inputs (?x)
    :domain (P ?x)
    :outputs (?y)
    :certified (Q ?x ?y)))
"""
BINDINGS_PROBLEM = GOOD_PROBLEM + "bindings: bindings.py\n"
GOOD_BINDINGS = """
def make_streams(world, rng):
    return {"next": lambda x: (x + "'",)}
"""


def error_of(path: Path) -> InputError:
    with pytest.raises(InputError) as caught:
        load_problem(path)
    return caught.value


def assert_at(error: InputError, path: Path, line: int, column: int, fragment: str) -> None:
    text = str(error)
    assert "\n" not in text
    assert text.startswith(f"{path}:{line}:{column}: "), text
    assert fragment in text, text


def test_good_files_load(make_problem: MakeProblem) -> None:
    path = make_problem(GOOD_DOMAIN, BINDINGS_PROBLEM, GOOD_STREAMS, GOOD_BINDINGS)
    problem = load_problem(path)
    assert solve(problem, PlannerConfig(algorithm="incremental", max_time=10)).solved


@pytest.mark.parametrize(("domain", "line", "column", "fragment"), [
    # the innermost list left open is reported
    ("(define (domain d)\n  (:predicates (P ?x)\n", 2, 3, "unclosed '('"),
    ("(define (domain d)))", 1, 20, "unexpected ')'"),
    ("(define (domain d)\n  (:constraints (P)))", 2, 3, "unknown domain section ':constraints'"),
    ("(define (domain d)\n  (:predicates (P ?x))\n  (:action a :parameters (?x)\n"
     "    :precondition (not (P ?x) (P ?x))\n    :effect (P ?x)))", 4, 19,
     "'not' takes exactly one formula"),
    ("(define (domain d)\n  (:predicates (P ?x))\n  (:action a :parameters (?x)"
     " :precondition (P ?x)))", 3, 3, "action 'a' has no :effect"),
    ("(define (domain d)\n  (:predicates (P ?x))\n  (:action a\n    :parameters (x)\n"
     "    :effect (P ?x)))", 4, 18, "expected a parameter of action 'a' (a '?variable')"),
    ("(define (domain d)\n  (:predicates (P ?x))\n  (:action a :parameters (?x)\n"
     "    :effect (and (P ?x) (increase (total-cost) ?x))))", 4, 48,
     "expected a number or a function term"),
    ("(define (domain d)\n  (:predicates (P ?x))\n  (:action a :parameters (?x)\n"
     "    :effect (and (P ?x) (decrease (total-cost) 1))))", 4, 25,
     "numeric effect 'decrease' is not supported"),
])
def test_malformed_domain(make_problem: MakeProblem, domain: str, line: int, column: int,
                          fragment: str) -> None:
    path = make_problem(domain, GOOD_PROBLEM)
    assert_at(error_of(path), path.parent / "dom" / "domain.pddl", line, column, fragment)


@pytest.mark.parametrize(("domain", "line", "column", "fragment"), [
    ("(define (domain d)\n  (:predicates (P ?x))\n  (:action a :parameters (?x)\n"
     "    :precondition (and (P ?x) (R ?x))\n    :effect (P ?x)))", 4, 31,
     "unknown predicate 'r' in action 'a'"),
    ("(define (domain d)\n  (:predicates (P ?x))\n  (:action a :parameters (?x)\n"
     "    :effect (P ?x ?x)))", 4, 13, "predicate 'p' takes 1 argument(s), got 2"),
    ("(define (domain d)\n  (:types block)\n  (:predicates (P ?x - blok))\n"
     "  (:action a :parameters (?x) :effect (P ?x)))", 3, 16, "unknown type 'blok' for '?x'"),
    ("(define (domain d)\n  (:predicates (P ?x))\n  (:action a :parameters (?x)\n"
     "    :effect (P ?y)))", 4, 13, "variable ?y is not a parameter in action 'a'"),
    ("(define (domain d)\n  (:predicates (P ?x))\n  (:derived (D ?x) (P ?x))\n"
     "  (:action a :parameters (?x) :effect (D ?x)))", 4, 39,
     "derived predicate 'd' cannot be an effect"),
    ("(define (domain d)\n  (:predicates (P ?x))\n  (:action a :parameters (?x)\n"
     "    :effect (and (P ?x) (increase (total-cost) (dist ?x)))))", 4, 48,
     "unknown function 'dist'"),
])
def test_domain_semantic_errors(make_problem: MakeProblem, domain: str, line: int,
                                column: int, fragment: str) -> None:
    path = make_problem(domain, GOOD_PROBLEM)
    assert_at(error_of(path), path.parent / "dom" / "domain.pddl", line, column, fragment)


@pytest.mark.parametrize(("streams", "line", "column", "fragment"), [
    ("(define (stream d)\n  (:stream s :inputs (?x)\n    :output (?y)\n"
     "    :certified (P ?y)))", 3, 5, "unexpected ':output' in stream 's'"),
    ("(define (stream d)\n  (:stream s :inputs (?x) :domain (P ?x) :outputs (?y)\n"
     "    :certified (and (P ?y) (Near ?x ?y) (Near ?y))))", 3, 41,
     "predicate 'near' takes 2 argument(s) where it is first used"),
    ("(define (stream d)\n  (:stream s :inputs (?x) :domain (Q ?x) :outputs (?y)\n"
     "    :certified (P ?y)))", 2, 35, "predicate 'q' takes 2 argument(s), got 1"),
    ("(define (stream d)\n  (:stream s :inputs (?x) :domain (P ?x) :outputs (?y)\n"
     "    :certified (P ?z)))", 3, 16, "variable ?z is not a parameter"),
    ("(define (stream d)\n  (:sampler s))", 2, 3, "unknown stream-file section ':sampler'"),
    ("(define (stream d)\n  (:stream s :inputs (?x) :domain (P ?x)\n"
     "    :certified (P ?x))", 1, 1, "unclosed '('"),  # (:stream is closed, define not
    ("(define (stream d)\n  (:rule :inputs (?x) :domain (P ?x)))", 2, 3,
     "a rule has no :certified facts"),
])
def test_bad_stream_file(make_problem: MakeProblem, streams: str, line: int, column: int,
                         fragment: str) -> None:
    path = make_problem(GOOD_DOMAIN, BINDINGS_PROBLEM, streams, GOOD_BINDINGS)
    assert_at(error_of(path), path.parent / "dom" / "stream.pddl", line, column, fragment)


@pytest.mark.parametrize(("problem", "line", "column", "fragment"), [
    ("domain: dom\nobjects: {a: null\ngoal: (P a)\n", 3, 5, "invalid YAML"),
    ("domain: dom\nobjects: {a: null}\ninit: [\"(P a)\", \"(R a)\"]\ngoal: (P a)\n", 3, 18,
     "unknown predicate 'r' in the initial state"),
    ("domain: dom\nobjects: {a: null}\ninit: [\"(P a)\"]\ngoal: (and (P a) (Q a))\n", 4, 18,
     "predicate 'q' takes 2 argument(s), got 1 in the goal"),
    ("domain: dom\nobjects: {a: null}\ninit: [\"(P a)\"]\ngoal: (and (P a) (P c))\n", 4, 18,
     "unknown object 'c' in the goal"),
    ("domain: dom\nobjects: {a: null}\ninit: [\"(P a)\"]\ngoal: (and (P a)\n", 4, 7,
     "unclosed '('"),
    ("domain: dom\nobjects:\n  a: {type: block}\ngoal: (P a)\n", 3, 6,
     "unknown type 'block' for object 'a'"),
    ("domain: dom\nobject: {a: null}\ngoal: (P a)\n", 2, 9, "unknown field 'object'"),
    ("domain: nowhere\ngoal: (P a)\n", 1, 9, "domain folder"),
    ("objects: {a: null}\ngoal: (P a)\n", 1, 1, "'domain' must name the domain folder"),
])
def test_bad_yaml_problem(make_problem: MakeProblem, problem: str, line: int, column: int,
                          fragment: str) -> None:
    path = make_problem(GOOD_DOMAIN, problem)
    assert_at(error_of(path), path, line, column, fragment)


def test_multiline_goal_error_position(make_problem: MakeProblem) -> None:
    problem = textwrap.dedent("""\
        domain: dom
        objects: {a: null, b: null}
        init: ["(P a)"]
        goal: >-
          (and (P a)
               (Q a b c))
    """)
    path = make_problem(GOOD_DOMAIN, problem)
    error = error_of(path)
    assert "predicate 'q' takes 2 argument(s), got 3" in str(error)
    # A folded scalar keeps its own line structure only approximately: the line must be
    # inside the goal block (lines 4-6) and the message still one line.
    assert error.location is not None and 4 <= error.location.line <= 6
    assert "\n" not in str(error)


def test_stream_without_binding(make_problem: MakeProblem) -> None:
    path = make_problem(GOOD_DOMAIN, BINDINGS_PROBLEM, GOOD_STREAMS,
                        "def make_streams(world, rng):\n    return {'other': len}\n")
    problem = load_problem(path)
    with pytest.raises(InputError) as caught:
        solve(problem, PlannerConfig(algorithm="incremental", max_time=5))
    text = str(caught.value)
    assert "\n" not in text
    assert "stream 'next' has no Python binding" in text and "other" in text


@pytest.mark.parametrize(("bindings", "fragment"), [
    ("import no_such_module_xyz\n", "failed to import: ModuleNotFoundError"),
    ("def make_streams(world, rng)\n    return {}\n", "failed to import: SyntaxError"),
    ("raise RuntimeError('boom')\n", "failed to import: RuntimeError: boom"),
    ("def other():\n    pass\n", "define no make_streams(world, rng) function"),
])
def test_bindings_that_fail_to_import(make_problem: MakeProblem, bindings: str,
                                      fragment: str) -> None:
    path = make_problem(GOOD_DOMAIN, BINDINGS_PROBLEM, GOOD_STREAMS, bindings)
    # "bindings: bindings.py" is on line 5 of the YAML, the value at column 11.
    assert_at(error_of(path), path, 5, 11, fragment)


def test_missing_bindings_field(make_problem: MakeProblem) -> None:
    path = make_problem(GOOD_DOMAIN, GOOD_PROBLEM, GOOD_STREAMS)
    error = error_of(path)
    assert "'bindings' must name a .py file or a module" in str(error)
    assert str(error).startswith(f"{path}:")


def test_binding_module_name_that_does_not_import(make_problem: MakeProblem) -> None:
    path = make_problem(GOOD_DOMAIN, GOOD_PROBLEM + "bindings: no_such_pkg.streams\n",
                        GOOD_STREAMS)
    assert_at(error_of(path), path, 5, 11, "bindings module 'no_such_pkg.streams' failed to "
              "import: ModuleNotFoundError")
