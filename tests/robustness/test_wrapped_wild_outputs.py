"""A test stream's WildOutput wrapped by ``from_gen_fn``/``from_fn``/``from_test`` is refused,
not taken as "true" with its facts dropped.

Round 7: a stream without outputs (it certifies only wild facts) whose generator was given
to ``stream_map`` through ``from_gen_fn`` yields ``[WildOutput(...)]``, a one-item output
list: the adapter took the list as a true test and dropped the facts. Every algorithm,
incremental included, answered "infeasible" for a problem whose plan needs them (PDDLStream
refuses the same input: "an output tuple ... is not a sequence"). ``from_test`` of a test
returning a WildOutput lost its facts the same way. A stream *with* outputs was already
refused in one line ("must produce tuples of 1 value(s)").
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream import (
    PDDLProblem,
    WildOutput,
    from_fn,
    from_gen_fn,
    from_test,
    solve,
)
from ltamp_cli.planner.algorithms.common import ALGORITHMS

DOMAIN = """(define (domain lamps)
  (:requirements :strips)
  (:predicates (Conf ?q) (AtConf ?q) (Lamp ?l) (Lights ?q ?l) (On ?l) (Region ?r))
  (:action move :parameters (?a ?b) :precondition (and (AtConf ?a) (Conf ?b))
    :effect (and (AtConf ?b) (not (AtConf ?a))))
  (:action switch :parameters (?q ?l) :precondition (and (AtConf ?q) (Lights ?q ?l))
    :effect (On ?l)))
"""
STREAM = """(define (stream lamps)
  (:stream sample :inputs (?r) :domain (Region ?r) :outputs (?q) :certified (Conf ?q))
  (:stream sense :inputs (?q) :domain (Conf ?q) :outputs ()))
"""
LAMP_X = 4.0


def _facts(q: float) -> list[tuple[Any, ...]]:
    return [("Lights", q, "l1")] if abs(q - LAMP_X) < 0.5 else []


def _sense_gen(q: float) -> Iterator[WildOutput]:
    yield WildOutput((), _facts(q))


def _sense_fn(q: float) -> WildOutput:
    return WildOutput((), _facts(q))


def _problem(sense: Callable[..., Any]) -> PDDLProblem:
    stream_map = {"sample": from_gen_fn(lambda r: iter([(1.0,), (LAMP_X,)])), "sense": sense}
    init = [("AtConf", 0.0), ("Conf", 0.0), ("Lamp", "l1"), ("Region", "r")]
    return PDDLProblem(DOMAIN, {}, STREAM, stream_map, init, ("On", "l1"))


WRAPPED = {"from_gen_fn": from_gen_fn(_sense_gen), "from_fn": from_fn(_sense_fn),
           "from_test": from_test(_sense_fn)}


@pytest.mark.parametrize("wrapper", sorted(WRAPPED))
@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_a_wrapped_wild_output_is_one_line(algorithm: str, wrapper: str) -> None:
    # before: "infeasible" (plan None) from every algorithm
    with pytest.raises(InputError, match=r"stream 'sense': .*WildOutput wrapped") as error:
        solve(_problem(WRAPPED[wrapper]), algorithm=algorithm, max_time=10, verbose=False)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("sense", [_sense_gen, _sense_fn], ids=["generator", "function"])
@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_an_unwrapped_wild_output_certifies_its_facts(algorithm: str,
                                                      sense: Callable[..., Any]) -> None:
    solution = solve(_problem(sense), algorithm=algorithm, max_time=10, verbose=False)
    assert solution.plan is not None, algorithm
    assert [(a.name, tuple(a.args)) for a in solution.plan] == [
        ("move", (0.0, LAMP_X)), ("switch", (LAMP_X, "l1"))]


def test_from_test_keeps_its_booleans() -> None:
    assert list(from_test(lambda q: q > 1)(2)) == [[()]]
    assert list(from_test(lambda q: q > 1)(0)) == [[]]
