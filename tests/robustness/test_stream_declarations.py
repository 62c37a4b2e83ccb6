"""Round 4: stream declarations PDDLStream refuses, and legal ones it accepts.

Bug this file caught (failed before the fix in ``planner/pddl/check.py``): a stream with
``:outputs (?p ?p)`` was accepted, its procedure's two values bound to one variable and the
first silently dropped (the plan placed the block at the second value); ``:inputs (?b ?b)``
called the procedure with one object twice. PDDLStream refuses both ("Output [?p] for
stream [bad] is not unique"); ltamp now refuses them in one line with file:line:col.

Held (accepted as PDDLStream accepts them, and solved by every algorithm): a generator
with no inputs, a test with neither inputs nor outputs, an output no certified fact uses.
"""

from __future__ import annotations

import re
from typing import Any

import pytest

from ltamp_cli.pddlstream import InputError, PDDLProblem, from_fn, from_gen_fn, from_test, solve

DOMAIN = """
(define (domain place)
  (:requirements :strips)
  (:constants done)
  (:predicates (Block ?b) (Pose ?b ?p) (AtPose ?b ?p) (Placed ?b) (Goal ?p) (Ready) (Spot ?p))
  (:action place
    :parameters (?b ?p)
    :precondition (and (Block ?b) (Pose ?b ?p))
    :effect (and (AtPose ?b ?p) (Placed ?b)))
  (:action spot :parameters (?p) :precondition (Spot ?p) :effect (Goal ?p))
  (:action ready :parameters () :precondition (Ready) :effect (Goal done)))
"""
ALGORITHMS = ("adaptive", "binding", "focused", "incremental")


def _solve(stream: str, stream_map: dict[str, Any], goal: Any, algorithm: str) -> Any:
    problem = PDDLProblem(DOMAIN, {}, f"(define (stream place)\n {stream})", stream_map,
                          [("Block", "a")], goal)
    return solve(problem, algorithm=algorithm, max_time=10)


@pytest.mark.parametrize("algorithm", ALGORITHMS)
@pytest.mark.parametrize("stream, procedure, message", [
    ("(:stream bad :inputs (?b) :domain (Block ?b) :outputs (?p ?p) :certified (Pose ?b ?p))",
     from_gen_fn(lambda b: iter([(1.0, 2.0)])), "?p is listed twice as an output of stream 'bad'"),
    ("(:stream bad :inputs (?b ?b) :domain (Block ?b) :outputs (?p) :certified (Pose ?b ?p))",
     from_gen_fn(lambda b, c: iter([(3.0,)])), "?b is listed twice as an input of stream 'bad'"),
])
def test_repeated_stream_variables_are_refused(algorithm: str, stream: str, procedure: Any,
                                               message: str) -> None:
    with pytest.raises(InputError) as caught:
        _solve(stream, {"bad": procedure}, ("Placed", "a"), algorithm)
    text = str(caught.value)
    assert "\n" not in text
    assert re.match(r"stream\.pddl:2:2: ", text), text
    assert text.endswith(message), text


@pytest.mark.parametrize("algorithm", ALGORITHMS)
@pytest.mark.parametrize("stream, stream_map, goal, plan", [
    ("(:stream sample-spot :outputs (?p) :certified (Spot ?p))",
     {"sample-spot": from_gen_fn(lambda: iter([(7.0,)]))},
     ("exists", ("?p",), ("Goal", "?p")), [("spot", (7.0,))]),
    ("(:stream sample-spot :inputs () :outputs (?p) :certified (Spot ?p))",
     {"sample-spot": from_fn(lambda: (7.0,))},
     ("exists", ("?p",), ("Goal", "?p")), [("spot", (7.0,))]),
    ("(:stream ready :certified (Ready))", {"ready": from_test(lambda: True)},
     ("Goal", "done"), [("ready", ())]),
    ("(:stream ready :certified (Ready))", {"ready": from_test(lambda: False)},
     ("Goal", "done"), None),
    ("(:stream two :inputs (?b) :domain (Block ?b) :outputs (?p ?q) :certified (Pose ?b ?p))",
     {"two": from_gen_fn(lambda b: iter([(4.0, 9.0)]))}, ("Placed", "a"), [("place", ("a", 4.0))]),
])
def test_streams_without_inputs_or_outputs_solve(algorithm: str, stream: str,
                                                 stream_map: dict[str, Any], goal: Any,
                                                 plan: Any) -> None:
    found = _solve(stream, stream_map, goal, algorithm)[0]
    if plan is None:
        assert found is None
    else:
        assert [(a.name, tuple(a.args)) for a in found] == plan
