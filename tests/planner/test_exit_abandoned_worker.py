"""A script that ends right after a solve whose worker was abandoned (red-team round 9).

The worker of a timed-out solve is a daemon thread; a stream call that was still running
native code when the script ended met an interpreter that was finalising (after long 3D
solves: "Fatal Python error: PyGILState_Release ... finalizing", the process aborted). The
stand-in here is a stream whose first call sleeps in C (``time.sleep``) past the solve's
deadline and then writes a marker: before the fix the interpreter finalised while the
worker slept, and the worker vanished when it woke (no marker); now the exit waits, a
bounded time, for abandoned workers to end.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

SCRIPT = textwrap.dedent("""
    import sys, time
    from pathlib import Path
    from ltamp_cli.pddlstream import PDDLProblem, from_gen_fn, solve

    DOMAIN = '''(define (domain d) (:predicates (Q ?q) (At ?q))
      (:action go :parameters (?a ?b) :precondition (and (At ?a) (Q ?b))
        :effect (and (At ?b) (not (At ?a)))))'''
    STREAM = '''(define (stream d) (:stream sample :inputs () :domain () :outputs (?q)
      :certified (Q ?q)))'''
    marker = Path(sys.argv[1])
    sleep_s = float(sys.argv[2])

    def sample():
        time.sleep(sleep_s)  # native code, past the solve's deadline
        marker.write_text("the abandoned worker ran to the end of its call")
        yield (1,)

    problem = PDDLProblem(DOMAIN, {}, STREAM, {"sample": from_gen_fn(sample)},
                          [("At", 0)], ("At", 1))
    solution = solve(problem, max_time=0.2, verbose=False)
    print("plan", solution.plan, flush=True)
""")


def _run(tmp_path: Path, sleep_s: float) -> tuple[subprocess.CompletedProcess[str], Path]:
    script = tmp_path / "script.py"
    script.write_text(SCRIPT)
    marker = tmp_path / "marker.txt"
    env = {"PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
           "PATH": "/usr/bin:/bin"}
    done = subprocess.run([sys.executable, str(script), str(marker), str(sleep_s)],
                          capture_output=True, text=True, env=env, timeout=180,
                          cwd=tmp_path)
    return done, marker


def test_the_exit_waits_for_an_abandoned_worker(tmp_path: Path) -> None:
    done, marker = _run(tmp_path, 2.0)
    assert done.returncode == 0, done.stderr
    assert "plan None" in done.stdout  # the solve timed out, abandoned its worker
    assert "Fatal Python error" not in done.stderr
    assert marker.exists(), "the interpreter finalised while the worker was in its call"


@pytest.mark.slow
def test_a_worker_that_never_returns_does_not_hold_the_exit(tmp_path: Path) -> None:
    # Sleeps for an hour: the exit waits for it at most EXIT_WAIT_S (the subprocess's
    # timeout, 180 s, would fail the test long before the hour).
    done, marker = _run(tmp_path, 3600.0)
    assert done.returncode == 0, done.stderr
    assert "Fatal Python error" not in done.stderr
    assert not marker.exists()
