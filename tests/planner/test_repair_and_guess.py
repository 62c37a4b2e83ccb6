"""Effort savers that keep the planner's answers: checking a bound optimistic plan before
searching, local repair of a failed test by resampling, sampled CPU timing of stream calls."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from line_domain import LINE_BINDINGS, LINE_DOMAIN, LINE_STREAMS

from ltamp_cli.planner.algorithms import focused, incremental, skeletons
from ltamp_cli.planner.algorithms.common import PlannerConfig, initial_state
from ltamp_cli.planner.algorithms.effort import observed_cheap
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import PlanningProblem, load_problem
from ltamp_cli.planner.search.solve import plan_discrete
from ltamp_cli.planner.streams import CPU_TIMED_FIRST_CALLS
from ltamp_cli.planner.validate import validate_plan

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"

# Two items each need a spot; two placed items must be certified apart (a negated test
# through a derived predicate, as collisions are in tamp2d).
SLOTS_DOMAIN = """
(define (domain slots)
  (:predicates (Item ?i) (Spot ?i ?s) (Placed ?i ?s) (Apart ?i ?s ?j ?t) (Done ?i)
               (Clash ?i ?s))
  (:derived (Clash ?i ?s)
    (exists (?j ?t) (and (Spot ?i ?s) (Placed ?j ?t) (not (= ?i ?j))
                         (not (Apart ?i ?s ?j ?t)))))
  (:action place
    :parameters (?i ?s)
    :precondition (and (Item ?i) (Spot ?i ?s) (not (Done ?i)) (not (Clash ?i ?s)))
    :effect (and (Placed ?i ?s) (Done ?i))))
"""
SLOTS_STREAMS = """
(define (stream slots)
  (:stream sample-spot
    :inputs (?i)
    :domain (Item ?i)
    :outputs (?s)
    :certified (Spot ?i ?s))
  (:stream test-apart
    :inputs (?i ?s ?j ?t)
    :domain (and (Spot ?i ?s) (Spot ?j ?t))
    :certified (Apart ?i ?s ?j ?t)))
"""
# Spots come from fixed sequences: b's first spot (1) is too close to a's (0), its second
# (4) is fine. Spots are apart when at least 2 apart.
SLOTS_BINDINGS = """
def make_streams(world, rng):
    sequences = {"a": [0, 10, 20, 30], "b": [1, 4, 7, 11]}

    def sample_spot(item):
        for spot in sequences[item]:
            yield (spot,)

    return {"sample-spot": sample_spot, "test-apart": lambda i, s, j, t: abs(s - t) >= 2}
"""
SLOTS_PROBLEM = """
domain: dom
bindings: bindings.py
objects: {a: null, b: null}
init: ["(Item a)", "(Item b)"]
goal: (and (Done a) (Done b))
"""


def slots_problem(make_problem) -> PlanningProblem:  # type: ignore[no-untyped-def]
    return load_problem(make_problem(SLOTS_DOMAIN, SLOTS_PROBLEM, SLOTS_STREAMS,
                                     SLOTS_BINDINGS))


@pytest.mark.parametrize("algorithm", ["binding", "focused"])
def test_local_repair_resamples_instead_of_searching_again(
        make_problem, monkeypatch: pytest.MonkeyPatch, algorithm: str) -> None:  # type: ignore[no-untyped-def]
    problem = slots_problem(make_problem)
    # Complexity 2 from the start: the first search already finds the plan's skeleton, so
    # no failed search has raised binding's retry bound yet.
    config = PlannerConfig(algorithm=algorithm, max_time=20, initial_complexity=2)
    repaired = solve(problem, config)
    assert repaired.solved
    assert validate_plan(problem, repaired).valid
    spots = {step.values[0]: step.values[1] for step in repaired.plan}
    assert abs(spots["a"] - spots["b"]) >= 2
    # Without local repair the collision of the first two spots sends the algorithm back to
    # search (the same answer, more searches).
    monkeypatch.setattr(skeletons, "MAX_LOCAL_REPAIRS", 0)
    monkeypatch.setattr(focused, "MAX_LOCAL_REPAIRS", 0)
    searched = solve(problem, config)
    assert searched.solved
    assert repaired.stats["searches"] < searched.stats["searches"]
    assert [s.values for s in searched.plan] == [s.values for s in repaired.plan]


def test_a_valid_guess_is_the_plan_without_search() -> None:
    problem = load_problem(EXAMPLES / "blocksworld.yaml")
    objects = {name: type_name for name, (type_name, _) in problem.objects.items()}
    init = [(atom.predicate, *atom.args) for atom in problem.init]

    def discrete(**options: object):  # type: ignore[no-untyped-def]
        return plan_discrete(problem.domain, objects, init, {}, problem.goal,
                             time.perf_counter() + 30, **options)  # type: ignore[arg-type]

    searched = discrete()
    assert searched.solved and searched.outcome is not None
    assert searched.outcome.expanded > 0 and not searched.outcome.guessed
    plan = [(a.name, a.args) for a in searched.actions or []]
    followed = discrete(guess=plan)
    assert followed.outcome is not None and followed.outcome.guessed
    assert followed.outcome.expanded == 0
    assert [(a.name, a.args) for a in followed.actions or []] == plan
    # A guess that misses the goal or breaks a precondition is ignored: the search runs.
    for wrong in (plan[:-1], plan[1:]):
        fallback = discrete(guess=wrong)
        assert fallback.solved and fallback.outcome is not None
        assert not fallback.outcome.guessed and fallback.outcome.expanded > 0


def test_stream_cpu_time_is_measured_on_a_sample_of_calls(make_problem) -> None:  # type: ignore[no-untyped-def]
    text = ("domain: dom\nbindings: bindings.py\nworld: {top: 3, goal: 2}\n"
            "objects: {p0: 0}\ninit: [\"(Pos p0)\", \"(At p0)\"]\n"
            "goal: (exists (?p) (and (At ?p) (Goal ?p)))\n")
    problem = load_problem(make_problem(LINE_DOMAIN, text, LINE_STREAMS, LINE_BINDINGS))
    state = initial_state(problem, PlannerConfig())
    for i in range(40):
        state.objects.add(f"v{i}", i)
        state.call(state.instance("test-goal", (f"v{i}",)))
    stats = state.stream_stats["test-goal"]
    assert stats.calls == 40
    assert CPU_TIMED_FIRST_CALLS <= stats.cpu_timed_calls < 40
    # Untimed calls count at the measured mean, so the total stays a per-call estimate.
    assert 0.0 < stats.cpu_s < 40 * 1e-3
    assert observed_cheap(None, stats)


# The line domain with its goal test declared eager (StreamInfo.eager).
EAGER_LINE_BINDINGS = """
from ltamp_cli.planner.streams import Binding, StreamInfo


def make_streams(world, rng):
    def next_(p):
        if p + 1 <= world["top"]:
            yield (p + 1,)
    return {"next": next_,
            "test-goal": Binding(lambda p: p == world["goal"], StreamInfo(eager=True))}
"""


def test_incremental_evaluates_eager_streams_before_each_search(
        make_problem, monkeypatch: pytest.MonkeyPatch) -> None:  # type: ignore[no-untyped-def]
    text = ("domain: dom\nbindings: bindings.py\nworld: {top: 6, goal: 3}\n"
            "objects: {p0: 0}\ninit: [\"(Pos p0)\", \"(At p0)\"]\n"
            "goal: (exists (?p) (and (At ?p) (Goal ?p)))\n")
    problem = load_problem(make_problem(LINE_DOMAIN, text, LINE_STREAMS,
                                        EAGER_LINE_BINDINGS))
    config = PlannerConfig(algorithm="incremental", max_time=20)
    eager = solve(problem, config)
    assert eager.solved and [s.values for s in eager.plan] == [(0, 1), (1, 2), (2, 3)]
    # One level of values per iteration: position 3 is sampled in the third round, and its
    # eager goal test runs before the fourth search instead of one round later.
    monkeypatch.setattr(incremental, "evaluate_eager_steps", lambda state: iter(()))
    lagging = solve(problem, config)
    assert lagging.solved and [s.values for s in lagging.plan] == [(0, 1), (1, 2), (2, 3)]
    assert eager.stats["searches"] == lagging.stats["searches"] - 1
