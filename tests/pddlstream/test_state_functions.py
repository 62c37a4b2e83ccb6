"""Issue #18 (PDDLStream's continuous_tamp/unfactored): planning over whole states, with
functions from a state (and a motion or a position) to the successor state.

The problem is written for this test, in the shape of that example: a robot and one box on
a line; the state is the tuple (robot position, box position, or ``None`` while held).
``forward-move`` / ``forward-pick`` / ``forward-place`` return the successor state, or
``None`` when the transition does not apply (the robot is elsewhere, the hand is empty);
``sample-pos`` samples positions in a region, ``plan-motion`` joins two positions, and
``test-goal`` accepts a state with the box in the goal region and the robot back home. The
domain's actions only follow ``(Move ...)``/``(Pick ...)``/``(Place ...)`` facts between
states, so an optimistic plan knows nothing of a state's contents: every transition from a
real state looks applicable. The plan needs five transitions (move, pick, move, place,
move).

Before the fix adaptive timed out (10 s wall, seeds 0 and 1): each search tried one
transition from a real state that the function then rejected, and each new position sample
(at level 0) opened one more such one-step plan, so the bound hardly grew. Now calls of the
streams feeding the cycle (positions, motions) raise their outputs' level as the cycle's own
do, and cheap functions on or feeding the cycle are called on every real input below the
complexity bound (the successors of the real states are then known at once, as PDDLStream's
incremental algorithm finds them): solved in well under a second of CPU.
"""

from __future__ import annotations

import textwrap
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ltamp_cli.pddlstream import PDDLProblem, from_fn, from_gen_fn, from_test, read, solve

HOME = 0.0
BOX = 2.0
GOAL = (4.0, 5.0)

DOMAIN = """
(define (domain line)
  (:requirements :strips)
  (:predicates (Move ?s1 ?x1 ?t ?x2 ?s2) (Pick ?s1 ?x ?s2) (Place ?s1 ?x ?s2)
               (AtState ?s) (AtGoal) (SatisfiesGoal ?s))
  (:action move
    :parameters (?s1 ?x1 ?t ?x2 ?s2)
    :precondition (and (Move ?s1 ?x1 ?t ?x2 ?s2) (AtState ?s1))
    :effect (and (AtState ?s2) (not (AtState ?s1))))
  (:action pick
    :parameters (?s1 ?x ?s2)
    :precondition (and (Pick ?s1 ?x ?s2) (AtState ?s1))
    :effect (and (AtState ?s2) (not (AtState ?s1))))
  (:action place
    :parameters (?s1 ?x ?s2)
    :precondition (and (Place ?s1 ?x ?s2) (AtState ?s1))
    :effect (and (AtState ?s2) (not (AtState ?s1))))
  (:derived (AtGoal) (exists (?s) (and (SatisfiesGoal ?s) (AtState ?s)))))
"""

STREAMS = """
(define (stream line)
  (:stream sample-pos
    :inputs (?r) :domain (Region ?r)
    :outputs (?x) :certified (Pos ?x))
  (:stream plan-motion
    :inputs (?x1 ?x2) :domain (and (Pos ?x1) (Pos ?x2))
    :outputs (?t) :certified (Motion ?x1 ?t ?x2))
  (:stream forward-move
    :inputs (?s1 ?x1 ?t ?x2) :domain (and (State ?s1) (Motion ?x1 ?t ?x2))
    :outputs (?s2) :certified (and (State ?s2) (Move ?s1 ?x1 ?t ?x2 ?s2)))
  (:stream forward-pick
    :inputs (?s1 ?x) :domain (and (State ?s1) (Pos ?x))
    :outputs (?s2) :certified (and (State ?s2) (Pick ?s1 ?x ?s2)))
  (:stream forward-place
    :inputs (?s1 ?x) :domain (and (State ?s1) (Pos ?x))
    :outputs (?s2) :certified (and (State ?s2) (Place ?s1 ?x ?s2)))
  (:stream test-goal
    :inputs (?s) :domain (State ?s)
    :certified (SatisfiesGoal ?s)))
"""

State = tuple[float, float | None]


def line_problem(folder: Path, seed: int) -> PDDLProblem:
    rng = np.random.default_rng(seed)
    regions = {"goal": GOAL, "floor": (0.0, 6.0)}

    def sample(region: str) -> Any:
        low, high = regions[region]
        while True:
            yield (round(float(rng.uniform(low, high)), 6),)

    def motion(x1: float, x2: float) -> tuple[tuple[float, float]]:
        return ((x1, x2),)

    def move(s: State, x1: float, t: tuple[float, float], x2: float) -> tuple[State] | None:
        return ((x2, s[1]),) if s[0] == x1 else None

    def pick(s: State, x: float) -> tuple[State] | None:
        return ((s[0], None),) if s[0] == x and s[1] == x else None

    def place(s: State, x: float) -> tuple[State] | None:
        return ((s[0], x),) if s[0] == x and s[1] is None else None

    def at_goal(s: State) -> bool:
        return s[0] == HOME and s[1] is not None and GOAL[0] <= s[1] <= GOAL[1]

    for name, text in (("domain.pddl", DOMAIN), ("stream.pddl", STREAMS)):
        (folder / name).write_text(textwrap.dedent(text).lstrip())
    start: State = (HOME, BOX)
    init = [("State", start), ("AtState", start), ("Pos", HOME), ("Pos", BOX),
            ("Region", "goal"), ("Region", "floor")]
    stream_map = {"sample-pos": from_gen_fn(sample), "plan-motion": from_fn(motion),
                  "forward-move": from_fn(move), "forward-pick": from_fn(pick),
                  "forward-place": from_fn(place), "test-goal": from_test(at_goal)}
    return PDDLProblem(read(folder / "domain.pddl"), {}, read(folder / "stream.pddl"),
                       stream_map, init, ("AtGoal",))


@pytest.mark.parametrize("seed", [0, 1])
def test_adaptive_plans_over_whole_states(tmp_path: Path, seed: int) -> None:
    """The returned plan's states carry the box to the goal region and the robot home
    (checked on the values): move to the box, pick, move into the region, place, move
    home."""
    start = time.process_time()
    solution = solve(line_problem(tmp_path, seed), algorithm="adaptive", max_time=10.0,
                     verbose=False)
    assert solution.plan is not None, f"no plan after {time.process_time() - start:.1f} s CPU"
    assert [step.name for step in solution.plan] == ["move", "pick", "move", "place", "move"]
    states = [step.args[-1] for step in solution.plan]
    final = states[-1]
    assert final[0] == HOME and GOAL[0] <= final[1] <= GOAL[1]
    assert states[1] == (BOX, None)  # holding the box where it stood
