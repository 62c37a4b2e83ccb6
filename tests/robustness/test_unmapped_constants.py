"""A domain constant that ``constant_map`` leaves out is named, in ``init`` and the goal, by
its name in any case: names are case-insensitive.

``(:constants V1)`` with no ``constant_map`` entry takes its (lower-cased) name as its value,
so ``("Vase", "V1")`` in ``init`` became another object (the string "V1" differs from the
value "v1") and ``(Hits ?b V1)`` could never hold: every algorithm answered "infeasible"
without a word (PDDLStream itself refuses a constant missing from ``constant_map``).
"""

from __future__ import annotations

from typing import Any

import pytest

from ltamp_cli.pddlstream import And, Not, PDDLProblem, from_gen_fn, from_test, solve
from ltamp_cli.planner.algorithms.common import ALGORITHMS

DOMAIN = """(define (domain knock)
  (:requirements :strips :negative-preconditions)
  (:constants V1)
  (:predicates (Conf ?q) (AtConf ?q) (Vase ?v) (Hits ?q ?v) (Moved))
  (:action move :parameters (?a ?b)
    :precondition (and (AtConf ?a) (Conf ?b) (Hits ?b V1))
    :effect (and (AtConf ?b) (not (AtConf ?a)) (Moved))))
"""
STREAM = """(define (stream knock)
  (:stream sample :inputs () :domain () :outputs (?q) :certified (Conf ?q))
  (:stream hits :inputs (?q ?v) :domain (and (Conf ?q) (Vase ?v)) :certified (Hits ?q ?v)))
"""


def _problem(constant_map: dict[str, Any], vase: str) -> PDDLProblem:
    def samples() -> Any:
        yield from ((x,) for x in (1.0, 5.0, 9.0))

    stream_map = {"sample": from_gen_fn(samples),
                  "hits": from_test(lambda q, v: abs(q - 5.0) < 0.5)}
    init = [("Conf", 0.0), ("AtConf", 0.0), ("Vase", vase)]
    return PDDLProblem(DOMAIN, constant_map, STREAM, stream_map, init,
                       And(("Moved",), Not(("AtConf", 0.0))))


@pytest.mark.parametrize("vase", ["V1", "v1"])
@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_an_unmapped_constant_is_named_in_any_case(algorithm: str, vase: str) -> None:
    solution = solve(_problem({}, vase), algorithm=algorithm, max_time=20, verbose=False)
    assert solution.plan is not None, (algorithm, vase)  # before: None for "V1"
    assert [(a.name, a.args) for a in solution.plan] == [("move", (0.0, 5.0))]


@pytest.mark.parametrize("algorithm", ["incremental", "adaptive"])
def test_a_mapped_constant_keeps_its_value(algorithm: str) -> None:
    # constant_map gives V1 the value "v1": the string "V1" is another value (as in
    # PDDLStream, which keys objects by value), so that vase is not the constant
    assert solve(_problem({"V1": "v1"}, "V1"), algorithm=algorithm, max_time=20,
                 verbose=False).plan is None
    assert solve(_problem({"V1": "v1"}, "v1"), algorithm=algorithm, max_time=20,
                 verbose=False).plan is not None
