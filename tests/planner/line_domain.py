"""A tiny stream domain shared by the planner tests: values on a line."""

LINE_DOMAIN = """
(define (domain line)
  (:predicates (Pos ?p) (At ?p) (Step ?p ?q) (Goal ?p))
  (:action move
    :parameters (?p ?q)
    :precondition (and (At ?p) (Step ?p ?q))
    :effect (and (At ?q) (not (At ?p)))))
"""
LINE_STREAMS = """
(define (stream line)
  (:stream next
    :inputs (?p)
    :domain (Pos ?p)
    :outputs (?q)
    :certified (and (Pos ?q) (Step ?p ?q)))
  (:stream test-goal
    :inputs (?p)
    :domain (Pos ?p)
    :certified (Goal ?p)))
"""
# next(p) = p + 1 while below world["top"]; a goal pose is world["goal"].
LINE_BINDINGS = """
def make_streams(world, rng):
    def next_(p):
        if world["top"] is None or p + 1 <= world["top"]:
            yield (p + 1,)
    return {"next": next_, "test-goal": lambda p: p == world["goal"]}
"""
# A problem file over the line (domain folder ``dom``, bindings ``bindings.py``): ``next``
# goes on forever and no value is the goal, so a solve runs to its deadline.
UNREACHABLE = """
domain: dom
bindings: bindings.py
world: {top: null, goal: -1}
objects: {p0: 0}
init: ["(Pos p0)", "(At p0)"]
goal: (exists (?p) (and (At ?p) (Goal ?p)))
"""
