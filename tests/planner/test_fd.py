"""The optional Fast Downward search (``--search fd`` / ``fd-wastar``): every example solved
and validated, costs respected, unsolvable and timed-out searches reported as such, a
missing extra reported as bad input. Skipped when the ``fd`` extra is not installed."""

from __future__ import annotations

import importlib.util
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("fast_downward.translate")
if importlib.util.find_spec("up_fast_downward") is None:
    pytest.skip("the 'fd' extra (up-fast-downward) is not installed", allow_module_level=True)

from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import PlannerConfig, initial_state
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import PlanningProblem, load_problem
from ltamp_cli.planner.search import fast_downward
from ltamp_cli.planner.search.engine import SearchTimeout
from ltamp_cli.planner.search.fast_downward import (
    parse_plan,
    search_with_fast_downward,
    write_pddl,
)
from ltamp_cli.planner.search.solve import DiscreteResult
from ltamp_cli.planner.search.task import Task
from ltamp_cli.planner.validate import validate_plan

MakeProblem = Callable[..., Path]
REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "problems" / "examples"
FAST_EXAMPLES = ("blocksworld", "tamp2d_blocked", "tamp2d_4blocks", "synthetic_goodregion")
CASES = [
    *((name, algorithm, search) for name in FAST_EXAMPLES
      for algorithm in ("incremental", "focused") for search in ("fd", "fd-wastar")),
    *((name, algorithm, "fd") for name in FAST_EXAMPLES for algorithm in ("adaptive", "binding")),
    ("kitchen_symbolic", "incremental", "fd"),
    ("kitchen_symbolic", "incremental", "fd-wastar"),
    # ~5-25 s: the focused algorithm searches optimistic tasks of ~1000 operators 7-10 times.
    pytest.param("kitchen_symbolic", "focused", "fd", marks=pytest.mark.slow),
    pytest.param("kitchen_symbolic", "focused", "fd-wastar", marks=pytest.mark.slow),
]
PROBLEMS: dict[str, PlanningProblem] = {}


def example(name: str) -> PlanningProblem:
    if name not in PROBLEMS:
        PROBLEMS[name] = load_problem(EXAMPLES / f"{name}.yaml")
    return PROBLEMS[name]


def first_search(problem: PlanningProblem, search: str = "lazy-greedy",
                 unit_costs: bool = False) -> DiscreteResult:
    """The discrete search over the problem's initial facts (no stream calls)."""
    state = initial_state(problem, PlannerConfig(search=search, unit_costs=unit_costs,
                                                 max_time=60))
    return state.search(state.facts.members, state.object_types, state.function_values)


def blocksworld_task() -> Task:
    task = first_search(example("blocksworld")).task
    assert task is not None
    return task


@pytest.mark.parametrize(("name", "algorithm", "search"), CASES)
def test_examples_solved_and_validated(name: str, algorithm: str, search: str) -> None:
    problem = example(name)
    result = solve(problem, PlannerConfig(algorithm=algorithm, search=search, max_time=60))
    assert result.status == "solved", result.stats
    report = validate_plan(problem, result)
    assert report.valid, report.errors[:3]
    assert report.cost == pytest.approx(result.cost)
    assert result.stats["searches"] >= 1


def test_outcome_states_follow_the_plan() -> None:
    task = blocksworld_task()
    outcome = search_with_fast_downward(task, time.perf_counter() + 60)
    assert outcome.plan is not None and len(outcome.plan) >= 16  # every block must move
    assert len(outcome.states) == len(outcome.plan) + 1
    assert outcome.states[0] == task.init
    state = task.init
    for op, recorded in zip(outcome.plan, outcome.states[1:], strict=True):
        vector = task.state_vector(state)
        assert op in task.applicable(vector).tolist()
        state = task.successor(state, vector, op)
        assert state == recorded
    assert task.is_goal(task.state_vector(state))
    assert outcome.cost == pytest.approx(sum(task.operators[i].cost for i in outcome.plan))
    assert outcome.expanded >= 1 and outcome.evaluated >= 1


def test_blocksworld_cost_optimal_with_fd_wastar() -> None:
    # Each of the 8 blocks is misplaced and must be moved at least once (2 actions of
    # cost 1 per move): 16 is a lower bound, and reachable.
    result = solve(example("blocksworld"), PlannerConfig(search="fd-wastar", max_time=60))
    assert result.solved
    assert result.cost == pytest.approx(16.0)
    in_process = solve(example("blocksworld"), PlannerConfig(search="wastar", max_time=60))
    assert result.cost <= in_process.cost + 1e-9


# Two ways to the goal: three cheap hops (0.4 each, fractional: costs must be scaled for
# Fast Downward) or one expensive jump (3, more than twice the hops: weighted A* with w = 2
# must avoid it).
ROUTE_DOMAIN = """
(define (domain route)
  (:requirements :strips :action-costs)
  (:predicates (At ?p) (Hop ?p ?q) (Jump ?p ?q))
  (:functions (total-cost) - number)
  (:action hop
    :parameters (?p ?q)
    :precondition (and (At ?p) (Hop ?p ?q))
    :effect (and (At ?q) (not (At ?p)) (increase (total-cost) 0.4)))
  (:action jump
    :parameters (?p ?q)
    :precondition (and (At ?p) (Jump ?p ?q))
    :effect (and (At ?q) (not (At ?p)) (increase (total-cost) 3))))
"""
ROUTE_PROBLEM = """
domain: dom
objects: {a: null, b: null, c: null, d: null}
init: ["(At a)", "(Hop a b)", "(Hop b c)", "(Hop c d)", "(Jump a d)"]
goal: (At d)
"""


def test_fractional_costs_respected(make_problem: MakeProblem) -> None:
    problem = load_problem(make_problem(ROUTE_DOMAIN, ROUTE_PROBLEM))
    cheap = solve(problem, PlannerConfig(search="fd-wastar", max_time=30))
    assert [s.name for s in cheap.plan or []] == ["hop", "hop", "hop"]
    assert cheap.cost == pytest.approx(1.2)
    assert validate_plan(problem, cheap).valid
    short = solve(problem, PlannerConfig(search="fd-wastar", unit_costs=True, max_time=30))
    assert [s.name for s in short.plan or []] == ["jump"]
    assert short.cost == pytest.approx(3.0)  # the real cost, not the unit cost searched


def test_pddl_export_scales_fractional_costs(make_problem: MakeProblem) -> None:
    task = first_search(load_problem(make_problem(ROUTE_DOMAIN, ROUTE_PROBLEM))).task
    assert task is not None
    domain, problem, scale = write_pddl(task)
    assert scale == fast_downward.COST_SCALE
    assert "(increase (total-cost) 400)" in domain and "(increase (total-cost) 3000)" in domain
    assert "(:metric minimize (total-cost))" in problem
    unit_domain, unit_problem, unit_scale = write_pddl(task, unit_costs=True)
    assert unit_scale == 1 and "total-cost" not in unit_domain + unit_problem


# Relaxed-reachable (so the grounding keeps the goal) but unsolvable: each action destroys
# what the other achieved.
SWAP_DOMAIN = """
(define (domain swap)
  (:predicates (A) (B))
  (:action make-a :parameters () :precondition (and) :effect (and (A) (not (B))))
  (:action make-b :parameters () :precondition (and) :effect (and (B) (not (A)))))
"""
SWAP_PROBLEM = """
domain: dom
objects: {}
init: []
goal: (and (A) (B))
"""


@pytest.mark.parametrize("search", ["fd", "fd-wastar"])
def test_unsolvable_task_gives_no_plan(make_problem: MakeProblem, search: str) -> None:
    problem = load_problem(make_problem(SWAP_DOMAIN, SWAP_PROBLEM))
    discrete = first_search(problem, search)
    assert discrete.task is not None  # the goal is relaxed-reachable: FD had to decide
    assert not discrete.solved
    assert discrete.outcome is not None and discrete.outcome.plan is None
    assert discrete.outcome.cost == float("inf")
    result = solve(problem, PlannerConfig(algorithm="incremental", search=search, max_time=30))
    assert result.status == "infeasible"


@pytest.fixture
def started_processes(monkeypatch: pytest.MonkeyPatch) -> list[subprocess.Popen[Any]]:
    """Every process ``subprocess`` starts during the test, in order."""
    started: list[subprocess.Popen[Any]] = []

    class RecordedPopen(subprocess.Popen):  # type: ignore[type-arg]
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            started.append(self)

    monkeypatch.setattr(subprocess, "Popen", RecordedPopen)
    return started


def test_deadline_kills_fast_downward(started_processes: list[subprocess.Popen[Any]]) -> None:
    task = blocksworld_task()
    start = time.perf_counter()
    with pytest.raises(SearchTimeout):
        # Shorter than the translator's start-up: the subprocess must be stopped.
        search_with_fast_downward(task, start + 0.02)
    # Whatever the machine's load, no Fast Downward process outlives the call.
    assert all(process.returncode is not None for process in started_processes)
    with pytest.raises(SearchTimeout):
        search_with_fast_downward(task, start - 1.0)


def test_deadline_kills_a_translator_that_never_ends(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        started_processes: list[subprocess.Popen[Any]]) -> None:
    # A stand-in translator that would run for a minute: the deadline, not the process,
    # must end the call, and the process must be killed (returncode -SIGKILL), not left.
    stand_in = tmp_path / "python"
    stand_in.write_text("#!/bin/sh\nexec sleep 60\n")
    stand_in.chmod(0o755)
    real = fast_downward.locate_fast_downward()
    monkeypatch.setattr(fast_downward, "locate_fast_downward",
                        lambda: fast_downward.FastDownward(str(stand_in), real.downward))
    start = time.perf_counter()
    with pytest.raises(SearchTimeout):
        search_with_fast_downward(blocksworld_task(), start + 0.5)
    elapsed = time.perf_counter() - start
    assert len(started_processes) == 1
    assert started_processes[0].returncode == -signal.SIGKILL
    assert elapsed < 30.0  # the stand-in alone would take 60 s


def test_time_limit_gives_timeout_status() -> None:
    result = solve(example("kitchen_symbolic"),
                   PlannerConfig(algorithm="focused", search="fd", max_time=0.3))
    assert result.status == "timeout"
    assert result.plan is None
    assert result.time_s < 3.0


def test_missing_extra_is_bad_input(monkeypatch: pytest.MonkeyPatch) -> None:
    real_find_spec = importlib.util.find_spec

    def without_wheel(name: str, *args: Any, **kwargs: Any) -> Any:
        return None if name == "up_fast_downward" else real_find_spec(name, *args, **kwargs)

    monkeypatch.setattr(importlib.util, "find_spec", without_wheel)
    with pytest.raises(InputError, match=r"pip install ltamp\[fd\]"):
        solve(example("blocksworld"), PlannerConfig(search="fd", max_time=30))


def test_plan_parsing() -> None:
    assert parse_plan("(op3)\n(OP0 )\n; cost = 4 (general cost)\n", 4) == [3, 0]
    with pytest.raises(RuntimeError, match="unexpected line"):
        parse_plan("(op4)\n", 4)
    with pytest.raises(RuntimeError, match="unexpected line"):
        parse_plan("(pick-up a)\n", 4)


def test_cli_search_fd_writes_nothing_into_cwd(tmp_path: Path) -> None:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO),
           "PYTHONHASHSEED": "0"}
    run = subprocess.run([sys.executable, "-m", "ltamp_cli", "solve",
                          str(EXAMPLES / "tamp2d_blocked.yaml"), "--search", "fd", "--json"],
                         capture_output=True, text=True, timeout=120, env=env, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["status"] == "solved"
    assert list(tmp_path.iterdir()) == []


def test_goal_already_true_gives_empty_plan(make_problem: MakeProblem) -> None:
    domain = """
    (define (domain t)
      (:predicates (A) (B))
      (:action make-a :parameters () :precondition (and (B)) :effect (and (A))))
    """
    problem = load_problem(make_problem(domain, 'domain: dom\nobjects: {}\ninit: ["(A)"]\n'
                                                'goal: (A)\n'))
    discrete = first_search(problem, "fd")
    assert discrete.solved and discrete.actions == [] and discrete.task is not None
    assert discrete.outcome is not None and discrete.outcome.states == [discrete.task.init]
