"""Every PDDL / PDDLStream construct the issue lists parses into the expected syntax tree."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.planner.pddl.check import check_domain, check_problem, check_streams
from ltamp_cli.planner.pddl.parse import parse_domain, parse_problem, parse_stream_file
from ltamp_cli.planner.pddl.syntax import (
    And,
    AndEffect,
    Atom,
    Exists,
    ForAll,
    ForAllEffect,
    FunctionTerm,
    Imply,
    IncreaseCost,
    Literal,
    Not,
    Number,
    Or,
    TypedName,
    WhenEffect,
)
from ltamp_cli.planner.problem import load_problem

FULL_DOMAIN = textwrap.dedent("""
    ; every construct of the issue
    (define (domain Full)
      (:requirements :strips :typing :equality :derived-predicates :action-costs)
      (:types cup bowl - container container tool)
      (:constants home - object spoon1 - tool)
      (:predicates (At ?c - container ?p) (Clean ?c - container) (Holding ?t - tool)
                   (Free) (Dirty ?c - container) (Near ?p ?q))
      (:functions (Dist ?p ?q) - number (total-cost) - number)
      (:derived (Dirty ?c - container) (not (Clean ?c)))
      (:action move
        :parameters (?c - cup ?p ?q)
        :precondition (and (At ?c ?p) (not (= ?p ?q))
                           (or (Free) (Holding spoon1))
                           (imply (Dirty ?c) (Near ?p ?q))
                           (exists (?t - tool) (Holding ?t))
                           (forall (?b - bowl) (Clean ?b)))
        :effect (and (At ?c ?q) (not (At ?c ?p))
                     (forall (?b - bowl) (when (Near ?p ?q) (not (Clean ?b))))
                     (increase (total-cost) (Dist ?p ?q))))
      (:action rest
        :parameters ()
        :effect (and (Free) (increase (total-cost) 2.5))))
""")


def test_domain_sections_parse() -> None:
    domain = parse_domain(FULL_DOMAIN, "full.pddl")
    check_domain(domain)
    assert domain.name == "full"
    assert set(domain.types) == {("cup", "container"), ("bowl", "container"),
                                 ("container", "object"), ("tool", "object")}
    assert domain.constants == (TypedName("home", "object"), TypedName("spoon1", "tool"))
    predicates = domain.predicate_map()
    assert predicates["at"].parameters == (TypedName("?c", "container"), TypedName("?p"))
    assert predicates["free"].arity == 0
    assert [f.name for f in domain.functions] == ["dist", "total-cost"]
    assert domain.derived_predicates() == frozenset({"dirty"})
    assert domain.axioms[0].body == Not(Atom("clean", ("?c",)))


def test_action_formulas_and_effects_parse() -> None:
    move = parse_domain(FULL_DOMAIN, "full.pddl").actions[0]
    assert move.parameters == (TypedName("?c", "cup"), TypedName("?p"), TypedName("?q"))
    assert move.precondition == And((
        Atom("at", ("?c", "?p")),
        Not(Atom("=", ("?p", "?q"))),
        Or((Atom("free", ()), Atom("holding", ("spoon1",)))),
        Imply(Atom("dirty", ("?c",)), Atom("near", ("?p", "?q"))),
        Exists((TypedName("?t", "tool"),), Atom("holding", ("?t",))),
        ForAll((TypedName("?b", "bowl"),), Atom("clean", ("?b",))),
    ))
    assert move.effect == AndEffect((
        Literal(Atom("at", ("?c", "?q"))),
        Literal(Atom("at", ("?c", "?p")), positive=False),
        ForAllEffect((TypedName("?b", "bowl"),),
                     WhenEffect(Atom("near", ("?p", "?q")),
                                Literal(Atom("clean", ("?b",)), positive=False))),
        IncreaseCost(FunctionTerm("dist", ("?p", "?q"))),
    ))
    rest = parse_domain(FULL_DOMAIN, "full.pddl").actions[1]
    assert rest.effect == AndEffect((Literal(Atom("free", ())), IncreaseCost(Number(2.5))))


def test_pddl_problem_file_parses() -> None:
    domain = parse_domain(FULL_DOMAIN, "full.pddl")
    problem = parse_problem(textwrap.dedent("""
        (define (problem p1) (:domain full)
          (:objects c1 - cup b1 b2 - bowl a b)
          (:init (At c1 a) (Clean b1) (Free) (= (Dist a b) 3.5))
          (:goal (and (At c1 b) (forall (?x - bowl) (Clean ?x))))
          (:metric minimize (total-cost)))
    """), "p1.pddl")
    check_problem(problem, domain)
    assert problem.objects == (TypedName("c1", "cup"), TypedName("b1", "bowl"),
                               TypedName("b2", "bowl"), TypedName("a"), TypedName("b"))
    assert problem.init == (Atom("at", ("c1", "a")), Atom("clean", ("b1",)), Atom("free", ()))
    assert len(problem.function_values) == 1
    assert problem.function_values[0].term == FunctionTerm("dist", ("a", "b"))
    assert problem.function_values[0].value == 3.5
    assert problem.metric_minimize_cost
    assert isinstance(problem.goal, And) and isinstance(problem.goal.parts[1], ForAll)


STREAMS = textwrap.dedent("""
    (define (stream full)
      (:stream sample-place
        :inputs (?c)
        :domain (Clean ?c)
        :outputs (?p ?q)
        :certified (and (At ?c ?p) (Near ?p ?q)))
      (:stream test-near
        :inputs (?p ?q)
        :domain (and (Near ?p ?q) (Near ?q ?p))
        :certified (Near ?p ?p))
      (:stream fluent-stream
        :inputs (?c)
        :domain (Clean ?c)
        :fluents (At Holding)
        :outputs (?p)
        :certified (At ?c ?p))
      (:function (Dist ?p ?q) (and (Near ?p ?q)))
      (:predicate (Blocked ?p) (Near ?p ?p)))
""")


def test_stream_file_parses() -> None:
    domain = parse_domain(FULL_DOMAIN, "full.pddl")
    streams = parse_stream_file(STREAMS, "stream.pddl")
    check_streams(streams, domain)
    sample, test, fluent = streams.streams
    assert sample.inputs == ("?c",) and sample.outputs == ("?p", "?q")
    assert sample.domain == (Atom("clean", ("?c",)),)
    assert sample.certified == (Atom("at", ("?c", "?p")), Atom("near", ("?p", "?q")))
    assert not sample.is_test
    assert test.is_test and test.outputs == ()
    assert test.domain == (Atom("near", ("?p", "?q")), Atom("near", ("?q", "?p")))
    assert fluent.fluents == ("at", "holding")
    (function,) = streams.functions
    assert function.head == FunctionTerm("dist", ("?p", "?q"))
    assert function.domain == (Atom("near", ("?p", "?q")),)
    (predicate,) = streams.predicates
    assert predicate.head == Atom("blocked", ("?p",))
    assert streams.external_names() == ["sample-place", "test-near", "fluent-stream", "dist",
                                        "blocked"]


def test_yaml_problem_with_typed_objects_and_function_values(tmp_path: Path) -> None:
    folder = tmp_path / "full"
    folder.mkdir()
    (folder / "domain.pddl").write_text(FULL_DOMAIN)
    path = tmp_path / "p.yaml"
    path.write_text(textwrap.dedent("""
        domain: full
        objects:
          c1: {type: cup}
          b1: {type: bowl, value: [1, 2]}
          a: 0.5
          b: null
        init:
          - (At c1 a)
          - (= (Dist a b) 2)
        goal: (exists (?p) (At c1 ?p))
    """))
    problem = load_problem(path)
    assert problem.objects["c1"] == ("cup", None)
    assert problem.objects["b1"] == ("bowl", [1, 2])
    assert problem.objects["a"] == ("object", 0.5)
    assert problem.objects["home"] == ("object", None)  # domain constants become objects
    assert problem.init == (Atom("at", ("c1", "a")),)
    assert problem.function_values[0].value == 2.0
    assert problem.goal == Exists((TypedName("?p"),), Atom("at", ("c1", "?p")))


def test_pddl_problem_through_load_problem(tmp_path: Path) -> None:
    folder = tmp_path / "full"
    folder.mkdir()
    (folder / "domain.pddl").write_text(FULL_DOMAIN)
    pddl = tmp_path / "p.pddl"
    pddl.write_text("(define (problem q) (:domain full) (:objects c - cup x y)"
                    " (:init (At c x)) (:goal (At c y)))")
    problem = load_problem(pddl, folder)
    assert problem.objects["c"] == ("cup", None)
    assert problem.goal == Atom("at", ("c", "y"))


def test_locations_point_at_source() -> None:
    domain = parse_domain(FULL_DOMAIN, "full.pddl")
    move = domain.actions[0]
    # FULL_DOMAIN starts with a newline and a comment: "(:action move" is on line 11.
    assert (move.location.line, move.location.column) == (11, 3)
    first = move.precondition.parts[0]  # type: ignore[union-attr]
    assert (first.location.path, first.location.line, first.location.column) == (
        "full.pddl", 13, 24)


def test_a_derived_head_of_another_arity_than_its_declaration_is_refused_with_its_location():
    # Found by the fuzzer: grounding crashed (IndexError) on facts of two lengths.
    text = """(define (domain d)
  (:predicates (In ?b ?r) (At ?b ?r))
  (:derived (In ?b)
    (exists (?r) (At ?b ?r))))
"""
    domain = parse_domain(text, "d.pddl")
    with pytest.raises(InputError) as raised:
        check_domain(domain)
    message = str(raised.value)
    assert "'in' takes 2 argument(s)" in message and "got 1" in message
    assert "d.pddl:3:" in message
