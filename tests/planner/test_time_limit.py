"""The time limit is a bound: a solve returns within ``max_time + 1 s`` even when a stream
binding sleeps or never yields, names that stream, and bad ``max_time`` values are rejected
(API and CLI alike)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from line_domain import LINE_DOMAIN, LINE_STREAMS

from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem

MakeProblem = Callable[..., Path]
REPO = Path(__file__).resolve().parents[2]
MAX_TIME = 1.0
BOUND_S = MAX_TIME + 1.0

PROBLEM = """
domain: dom
bindings: bindings.py
world: {stuck_at: 2, goal: 4, release: RELEASE}
objects: {p0: 0}
init: ["(Pos p0)", "(At p0)"]
goal: (exists (?p) (and (At ?p) (Goal ?p)))
"""
# next(p) yields p + 1, except from p = world["stuck_at"], where it blocks until the file
# world["release"] exists (far longer than max_time): by sleeping, or by spinning without
# ever yielding. The release lets a test check that the abandoned worker then ends (and
# keeps the rest of the suite from sharing the interpreter with a spinning thread).
SLEEPING = """
import os
import time

def make_streams(world, rng):
    def next_(p):
        if p == world["stuck_at"]:
            while not os.path.exists(world["release"]):
                time.sleep(0.05)
        yield (p + 1,)
    return {"next": next_, "test-goal": lambda p: p == world["goal"]}
"""
SPINNING = """
import os

def make_streams(world, rng):
    def next_(p):
        if p == world["stuck_at"]:
            while not os.path.exists(world["release"]):
                pass
        yield (p + 1,)
    return {"next": next_, "test-goal": lambda p: p == world["goal"]}
"""


def blocking_problem(make_problem: MakeProblem, bindings: str, stuck_at: int = 2
                     ) -> tuple[Path, Path]:
    """The problem file and its release file (see :data:`SLEEPING`)."""
    path = make_problem(LINE_DOMAIN, "", LINE_STREAMS, bindings)
    release_file = path.parent / "release"
    path.write_text(PROBLEM.lstrip().replace("RELEASE", json.dumps(str(release_file)))
                    .replace("stuck_at: 2", f"stuck_at: {stuck_at}"))
    return path, release_file


def solver_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "ltamp-solve"]


def release_and_wait(release: Path) -> None:
    """Unblock the abandoned binding; its worker must then end by itself."""
    release.touch()
    deadline = time.monotonic() + 10.0
    while solver_threads() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not solver_threads(), "the abandoned worker did not end after its stream returned"


@pytest.mark.parametrize("bindings", [SLEEPING, SPINNING], ids=["sleeps", "never-yields"])
@pytest.mark.parametrize("algorithm", ["adaptive", "incremental"])
def test_blocking_stream_is_abandoned_at_the_deadline(
        make_problem: MakeProblem, bindings: str, algorithm: str) -> None:
    path, release = blocking_problem(make_problem, bindings)
    problem = load_problem(path)
    start = time.perf_counter()
    try:
        result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=MAX_TIME))
        elapsed = time.perf_counter() - start
    finally:
        release_and_wait(release)
    assert result.status == "timeout"
    assert MAX_TIME <= elapsed <= BOUND_S, elapsed
    assert result.time_s <= BOUND_S
    # The stuck call is named, with its input object (the value 2 interned by the stream).
    stopped = result.diagnostics["stopped_in"]
    assert stopped.startswith("stream 'next' (inputs ") and "running for" in stopped
    # What happened before it is reported: next was called on 0, 1 and 2 (at least).
    assert result.stats["streams"]["next"]["calls"] >= 3
    assert result.diagnostics["time_spent"]["per_stream"]["next"]["calls"] >= 3


def test_blocking_make_streams_is_abandoned(make_problem: MakeProblem) -> None:
    bindings = ("import os, time\n\ndef make_streams(world, rng):\n"
                "    while not os.path.exists(world['release']):\n        time.sleep(0.05)\n"
                "    return {}\n")
    path, release = blocking_problem(make_problem, bindings)
    problem = load_problem(path)
    start = time.perf_counter()
    try:
        result = solve(problem, PlannerConfig(max_time=MAX_TIME))
        assert time.perf_counter() - start <= BOUND_S
    finally:
        release_and_wait(release)
    assert result.status == "timeout"
    assert result.diagnostics["stopped_in"].startswith("stream 'make_streams'")


def test_the_solvable_variant_still_solves(make_problem: MakeProblem) -> None:
    """Control: the same problem without the blocking input plans quickly in the worker."""
    path, _ = blocking_problem(make_problem, SLEEPING, stuck_at=99)
    problem = load_problem(path)
    result = solve(problem, PlannerConfig(max_time=10.0))
    assert result.solved and [s.name for s in result.plan or []] == ["move"] * 4


@pytest.mark.parametrize("max_time", [math.nan, 0.0, -1.0])
def test_api_rejects_bad_max_time(max_time: float) -> None:
    problem = load_problem(REPO / "problems" / "examples" / "blocksworld.yaml")
    with pytest.raises(InputError, match="max time: expected a positive number"):
        solve(problem, PlannerConfig(max_time=max_time))


def _ltamp(*args: str | Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", "ltamp_cli", "solve", *map(str, args)],
                          capture_output=True, text=True, timeout=120, env=env, cwd=REPO)


@pytest.mark.parametrize("value", ["nan", "0", "-2.5"])
def test_cli_rejects_bad_max_time(value: str) -> None:
    run = _ltamp(REPO / "problems" / "examples" / "blocksworld.yaml", "--max-time", value)
    assert run.returncode == 2, (run.stdout, run.stderr)
    assert "Traceback" not in run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "--max-time" in lines[0], run.stderr


def test_cli_times_out_on_a_sleeping_stream_with_json_diagnostics(
        make_problem: MakeProblem) -> None:
    path, _ = blocking_problem(make_problem, SLEEPING)  # the process exits without release
    run = _ltamp(path, "--max-time", str(MAX_TIME), "--json", "--no-stats")
    assert run.returncode == 1, run.stderr
    data = json.loads(run.stdout)
    assert data["status"] == "timeout" and data["time_s"] <= BOUND_S
    spent = data["diagnostics"]["time_spent"]
    assert {"grounding_s", "search_s", "streams_s", "searches", "per_stream"} <= spent.keys()
    assert spent["searches"] >= 1
    assert spent["per_stream"]["next"]["calls"] >= 3
    assert "'next'" in data["diagnostics"]["stopped_in"]
