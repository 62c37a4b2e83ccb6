"""A solve interrupted in the caller's thread, and a process forked while a solve runs
(red-team round 8).

* Ctrl-C (``KeyboardInterrupt``) while the API waits for a solve reached the caller, but
  nobody told the worker thread: it went on calling the user's streams until ``max_time``
  (the drop-in API's default is ``inf``), then wrote stream statistics.
* A child forked while a solve ran in another thread (a ``multiprocessing`` pool under the
  default ``fork`` start method) inherited the paused collector and a depth count that no
  thread of the child would ever bring back to 0: automatic garbage collection stayed off
  in the child for good, through its own solves too.
"""

from __future__ import annotations

import _thread
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from line_domain import LINE_BINDINGS, LINE_DOMAIN, LINE_STREAMS, UNREACHABLE

from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem

MakeProblem = Callable[..., Path]
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def unreachable(make_problem: MakeProblem) -> Path:
    path = make_problem(LINE_DOMAIN, "", LINE_STREAMS, LINE_BINDINGS)
    path.write_text(UNREACHABLE.lstrip())
    return path


def test_an_interrupted_solve_stops_its_worker(unreachable: Path) -> None:
    problem = load_problem(unreachable)
    workers: list[threading.Thread] = []

    def interrupt() -> None:
        # Interrupt once the worker runs (under load, a fixed delay could fall in the
        # solve's set-up, before the caller waits for its worker): the interrupt must reach
        # the waiting caller.
        give_up = time.monotonic() + 60
        while not workers and time.monotonic() < give_up:
            time.sleep(0.05)
            workers.extend(t for t in threading.enumerate() if t.name == "ltamp-solve"
                           and t.is_alive())
        time.sleep(0.5)
        _thread.interrupt_main()

    # A process started in the background by a non-interactive shell (as CI may be) ignores
    # SIGINT, and then ``interrupt_main`` does nothing: give the test Python's handler.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Thread(target=interrupt, daemon=True)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            solve(problem, PlannerConfig(algorithm="adaptive", max_time=120))
    finally:
        signal.signal(signal.SIGINT, previous)
    assert workers, "the interrupt came before the solve's worker started"
    for worker in workers:
        worker.join(timeout=30)  # it stops at its next stream call or clock check
        assert not worker.is_alive()


FORK_SCRIPT = """
import gc, os, sys, threading, time
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem

problem = load_problem(sys.argv[1])
solving = threading.Thread(
    target=lambda: solve(problem, PlannerConfig(algorithm="adaptive", max_time=3)))
solving.start()
time.sleep(1.0)
assert not gc.isenabled()  # paused by the running solve
pid = os.fork()
if pid == 0:
    print("child", gc.isenabled(), flush=True)
    os._exit(0)
os.waitpid(pid, 0)
solving.join()
print("parent", gc.isenabled(), flush=True)
"""


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork on this platform")
def test_a_child_forked_during_a_solve_collects_garbage(unreachable: Path) -> None:
    run = subprocess.run([sys.executable, "-c", textwrap.dedent(FORK_SCRIPT), str(unreachable)],
                         capture_output=True, text=True, timeout=120, cwd=unreachable.parent,
                         env={**os.environ, "PYTHONPATH": str(REPO)})
    assert run.returncode == 0, run.stderr
    lines = [line for line in run.stdout.splitlines() if line.startswith(("child", "parent"))]
    assert lines == ["child True", "parent True"], run.stdout
