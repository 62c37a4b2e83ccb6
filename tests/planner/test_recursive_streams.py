"""Which streams can feed their own inputs (:func:`recursive_streams`): only their real
outputs get complexity levels that grow with their calls (issue #18, PDDLStream's rmmp)."""

from __future__ import annotations

from ltamp_cli.planner.algorithms.common import feeding_streams, recursive_streams
from ltamp_cli.planner.pddl.parse import parse_stream_file

# Successor states through two streams (a cycle of length 2), a junction stream fed by
# states but feeding nothing back, a test, and an acyclic pose -> configuration chain.
STREAMS = """
(define (stream cycles)
  (:stream grasp-state
    :inputs (?s1) :domain (Free ?s1)
    :outputs (?s2) :certified (Holding ?s2))
  (:stream place-state
    :inputs (?s1) :domain (Holding ?s1)
    :outputs (?s2) :certified (Free ?s2))
  (:stream junction
    :inputs (?s1) :domain (Free ?s1)
    :outputs (?h) :certified (Handle ?s1 ?h))
  (:stream test-ok
    :inputs (?s ?h) :domain (Handle ?s ?h)
    :certified (Ok ?s ?h))
  (:stream sample-pose
    :inputs (?b) :domain (Block ?b)
    :outputs (?p) :certified (Pose ?b ?p))
  (:stream ik
    :inputs (?b ?p) :domain (Pose ?b ?p)
    :outputs (?q) :certified (Conf ?q))
  (:stream sample-grip
    :inputs (?b) :domain (Block ?b)
    :outputs (?g) :certified (Grip ?g))
  (:stream grasp-with
    :inputs (?s1 ?g) :domain (and (Free ?s1) (Grip ?g))
    :outputs (?s2) :certified (Holding ?s2)))
"""


def test_only_streams_on_a_cycle_are_recursive() -> None:
    streams = parse_stream_file(STREAMS, "stream.pddl").streams
    assert recursive_streams(streams) == {"grasp-state", "place-state", "grasp-with"}


def test_streams_feeding_a_cycle() -> None:
    """``sample-grip`` feeds ``grasp-with`` (on the cycle); the pose -> configuration chain
    and the junction (fed by states, feeding only a test) do not feed one."""
    streams = parse_stream_file(STREAMS, "stream.pddl").streams
    assert feeding_streams(streams) == {"sample-grip"}


def test_a_self_feeding_stream_is_recursive() -> None:
    text = """
    (define (stream lock)
      (:stream s-extend :inputs (?s1) :domain (State ?s1)
        :outputs (?s2) :certified (and (State ?s2) (Next ?s1 ?s2))))
    """
    assert recursive_streams(parse_stream_file(text, "s.pddl").streams) == {"s-extend"}
