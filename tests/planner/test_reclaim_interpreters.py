"""The background reclaimer (:mod:`ltamp_cli.planner.reclaim`) on interpreters that differ
from CPython 3.11 (red-team round 8), and what the caller still holds after it ran.

Its safety rests on reading reference counts: a container is emptied only when nobody else
holds it. An interpreter whose counts omit references held on a caller's stack (3.14 loads
some locals as borrowed references) would make a container the caller still holds read as
exclusive, and the reclaimer emptied it; simulated here by a ``sys.getrefcount`` that
reads one less. Without ``sys._current_frames`` the watchdog raised ``AttributeError``
from every solve that came within a second of its deadline.
"""

from __future__ import annotations

import gc
import itertools
import sys
import time
from collections.abc import Iterator

import pytest

from ltamp_cli.pddlstream import PDDLProblem, from_gen_fn, from_test, solve
from ltamp_cli.planner import reclaim

DOMAIN = """(define (domain d)
  (:predicates (Region ?r) (Conf ?q) (Goal ?q) (Done))
  (:action finish :parameters (?q) :precondition (and (Conf ?q) (Goal ?q)) :effect (Done)))
"""
STREAM = """(define (stream d)
  (:stream sample :inputs (?r) :domain (Region ?r) :outputs (?q) :certified (Conf ?q))
  (:stream is-goal :inputs (?q) :domain (Conf ?q) :certified (Goal ?q)))
"""


def endless_problem(made: list[list[float]]) -> PDDLProblem:
    """No sample is a goal: the solve runs to its deadline. Every output is a list (an
    unhashable value) that ``made`` holds too."""

    def sample(region: str) -> Iterator[tuple[list[float]]]:
        for i in itertools.count():
            value = [float(i)] * 3
            made.append(value)
            yield (value,)

    return PDDLProblem(DOMAIN, {}, STREAM,
                       {"sample": from_gen_fn(sample), "is-goal": from_test(lambda q: False)},
                       [("Region", "r")], ("Done",))


def wait_for_release(timeout: float = 60.0) -> None:
    """Until the reclaimer's freeze hold ends (it ends when everything was freed)."""
    end = time.perf_counter() + timeout
    while gc.get_freeze_count() and time.perf_counter() < end:
        time.sleep(0.05)


def test_refcounts_are_exact_here() -> None:
    assert reclaim.refcounts_exact()


def test_under_reported_refcounts_take_nothing_apart(monkeypatch: pytest.MonkeyPatch) -> None:
    real = sys.getrefcount
    # One less than the truth (the lambda's own parameter is one more reference).
    monkeypatch.setattr(sys, "getrefcount", lambda value: real(value) - 2)
    shared = {i: (i, str(i)) for i in range(5000)}
    listed = list(range(5000))
    reclaim.take_apart([shared, listed])
    assert len(shared) == 5000 and len(listed) == 5000
    assert not reclaim.refcounts_exact()


def test_no_gil_takes_nothing_apart(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "_is_gil_enabled", lambda: False, raising=False)
    assert not reclaim.refcounts_exact()


def test_without_current_frames_a_solve_still_times_out(monkeypatch: pytest.MonkeyPatch
                                                         ) -> None:
    monkeypatch.delattr(sys, "_current_frames")
    made: list[list[float]] = []
    solution = solve(endless_problem(made), max_time=1.5)
    assert solution.plan is None and made


def test_outputs_the_caller_holds_survive_the_reclaimer() -> None:
    """Every value a stream made (held by the caller too) is intact once the background
    reclaimer, which took the solve's tables apart, is done."""
    made: list[list[float]] = []
    solution = solve(endless_problem(made), max_time=1.5)
    wait_for_release()
    assert solution.plan is None and len(made) > 3
    # Intact, not in order: past its grace the solve's interleaved incremental member has
    # its own generators, which count from 0 again. A taken-apart list would be empty.
    assert all(len(value) == 3 and value[0] == value[1] == value[2] for value in made)
