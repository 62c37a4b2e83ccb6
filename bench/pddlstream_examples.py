"""PDDLStream's own examples, run unmodified through ltamp's ``pddlstream`` alias.

Given a PDDLStream checkout, every ``examples/**/run.py`` (and the other example scripts
that call ``solve``) is run as PDDLStream's README runs it, ``python -m examples.X.run``
from the checkout, but through ltamp's runner (``ltamp pddlstream run -m examples.X.run``,
:mod:`ltamp_cli.pddlstream.run`): its ``pddlstream.*`` imports are served by
:mod:`ltamp_cli.pddlstream.alias`, nothing else is added (no shim, no file of the checkout's
``pddlstream/`` package is used). The checkout's own ``pddlstream`` package is importable
from there, so the runner is told to shadow it (``--force``).

Each example runs in its own child process (``--child``: a fresh interpreter, as a user's
run; stdin gives empty lines to ``user_input`` prompts, no display). In the child the alias
serves an instrumented ``solve`` (``install(overrides=...)``): it converts the problem
(load: parsing and checking the example's unmodified ``domain.pddl``/``stream.pddl``) and
solves it with ``adaptive`` whatever algorithm the example asks for (with its plan
constraints), recording load and
solve times and the outcome of each call. Examples that need modules not installed here
(pybullet, tkinter displays, Gurobi) or PDDLStream names ltamp does not provide are
reported as not loaded, with the runner's one-line reason. The runner adds back the
NumPy-1 names NumPy 2 removed (``np.mat``, ``np.product``, ...; see
:mod:`ltamp_cli.pddlstream.numpy_compat`) unless ``--no-numpy-compat``.

    .venv/bin/python bench/pddlstream_examples.py PATH/TO/pddlstream [--max-time 60]
        [--only continuous_tamp,advanced/wild] [--example-args '-n 4 -p blocked']
        [--out bench/results/pddlstream_examples.json] [--no-numpy-compat]

Without a checkout at PATH it prints why and exits 0 (never part of the tests or CI).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:  # the child runs as a script: make ltamp_cli importable
    sys.path.insert(0, str(REPO))

import ltamp_cli.pddlstream as api  # noqa: E402
from ltamp_cli.errors import InputError  # noqa: E402
from ltamp_cli.pddlstream.problem import to_planning_problem  # noqa: E402
from ltamp_cli.pddlstream.run import run_target  # noqa: E402
from ltamp_cli.pddlstream.satisfaction import (  # noqa: E402
    assignment_from_solution,
    compile_satisfaction,
)
from ltamp_cli.pddlstream.solve import plan_constraints, to_solution  # noqa: E402
from ltamp_cli.planner.algorithms.common import PlannerConfig  # noqa: E402
from ltamp_cli.planner.api import solve as plan  # noqa: E402

DEFAULT_OUT = REPO / "bench" / "results" / "pddlstream_examples.json"
SKIPPED_DIRS = ("retired", "todo", "pybullet")
# PDDLStream's solvers: whatever algorithm an example calls, the bench solves with adaptive.
SOLVERS = ("solve", "solve_adaptive", "solve_binding", "solve_focused", "solve_incremental")
SATISFIERS = ("constraint_satisfaction", "solve_pddlstream_satisfaction")
STDIN_LINES = "\n" * 100  # answers to the examples' user_input('Continue?') prompts


class Recorder:
    """What the served ``solve`` saw: load and solve times and the outcome of each call,
    written to ``record_path`` after every change (a child killed later keeps them)."""

    def __init__(self, max_time: float, record_path: Path) -> None:
        self.max_time = max_time
        self.record_path = record_path
        self.runs: list[dict[str, Any]] = []

    def save(self) -> None:
        self.record_path.write_text(json.dumps({"runs": self.runs}, default=str))

    def solve(self, problem: Any, stream_info: Any = None, constraints: Any = None,
              **_: Any) -> api.Solution:
        start = time.perf_counter()
        cpu_start = time.process_time()
        record: dict[str, Any] = {"loaded": False, "solved": False}
        self.runs.append(record)
        self.save()
        try:
            planning_problem = to_planning_problem(problem, stream_info)
        except InputError as error:
            record["error"] = str(error)
            self.save()
            raise
        record["loaded"] = True
        record["load_s"] = time.perf_counter() - start
        self.save()
        skeletons = plan_constraints(constraints, planning_problem)  # as solve() does
        config = PlannerConfig(algorithm="adaptive", max_time=self.max_time,
                               constraints=skeletons,
                               max_cost=getattr(constraints, "max_cost", float("inf")))
        result = plan(planning_problem, config)
        record.update(solved=result.solved, status=result.status, solve_s=result.time_s,
                      cpu_s=time.process_time() - cpu_start,
                      cost=result.cost if result.solved else None,
                      plan=[str(step) for step in result.plan or []])
        self.save()
        return to_solution(result)

    def satisfy(self, problem: Any, stream_info: Any = None, costs: bool = True,
                **_: Any) -> api.SatisfactionSolution:
        """PDDLStream's ``constraint_satisfaction``: compiled to planning, then solved as
        :meth:`solve` solves."""
        compiled = compile_satisfaction(problem, costs)
        solution = self.solve(compiled.problem, stream_info)
        return assignment_from_solution(compiled, solution.plan, solution.cost,
                                        solution.certificate)

    def solve_from_pddl(self, domain_pddl: str, problem_pddl: str, **_: Any) -> Any:
        start = time.perf_counter()
        cpu_start = time.process_time()
        record: dict[str, Any] = {"loaded": False, "solved": False}
        self.runs.append(record)
        found, cost = api.solve_from_pddl(domain_pddl, problem_pddl, max_time=self.max_time)
        record.update(loaded=True, load_s=0.0, solved=found is not None,
                      solve_s=time.perf_counter() - start,
                      cpu_s=time.process_time() - cpu_start, cost=cost,
                      plan=[str(step) for step in found or []])
        self.save()
        return found, cost

    def overrides(self) -> dict[str, Any]:
        served: dict[str, Any] = {name: self.solve for name in SOLVERS}
        served.update({name: self.satisfy for name in SATISFIERS})
        served["solve_from_pddl"] = self.solve_from_pddl
        return served


def child(module: str, example_args: Sequence[str], max_time: float, record: Path,
          numpy_compat: bool = True) -> int:
    """In the child process (cwd = the checkout): run ``module`` through the runner with the
    recording ``solve``; the runner's one-line errors and the script's output go to this
    process's stderr/stdout (the parent keeps their last lines)."""
    recorder = Recorder(max_time, record)
    recorder.save()
    code = run_target(module, example_args, module=True, force=True,
                      numpy_compat=numpy_compat, overrides=recorder.overrides())
    data = json.loads(record.read_text())
    data["exit_code"] = code
    record.write_text(json.dumps(data, default=str))
    return code


def example_scripts(checkout: Path) -> list[Path]:
    """Example scripts that call ``solve`` and define ``main``, outside skipped folders."""
    scripts = []
    for path in sorted((checkout / "examples").rglob("*.py")):
        relative = path.relative_to(checkout / "examples")
        if relative.parts[0] in SKIPPED_DIRS:
            continue
        text = path.read_text(errors="replace")
        if "def main(" in text and "solve" in text and "__main__" in text:
            scripts.append(path)
    return scripts


def module_name(checkout: Path, path: Path) -> str:
    return ".".join(path.relative_to(checkout).with_suffix("").parts)


def _error_line(stderr: str) -> str:
    """The runner's one-line reason (``ltamp: ...``), else the last line of stderr."""
    lines = [line for line in stderr.splitlines() if line.strip()]
    for line in reversed(lines):
        if line.startswith("ltamp: error: "):
            return line[len("ltamp: error: "):]
    if lines and lines[-1].startswith("ltamp: the script"):
        # The script's own exception is the line before the runner's note.
        return lines[-2] if len(lines) >= 2 else lines[-1]
    return lines[-1] if lines else ""


def run_example(checkout: Path, path: Path, max_time: float,
                example_args: Sequence[str] = (), numpy_compat: bool = True) -> dict[str, Any]:
    """Run one example in a child process; summarise its first ``solve``."""
    name = module_name(checkout, path)
    row: dict[str, Any] = {"example": str(path.relative_to(checkout / "examples")),
                           "module": name, "loaded": False, "solved": False}
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])]),
        "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    env.pop("DISPLAY", None)
    timeout = 3 * max_time + 60  # examples that solve more than once, plus start-up
    with tempfile.TemporaryDirectory() as scratch:
        record = Path(scratch) / "record.json"
        command = [sys.executable, str(Path(__file__).resolve()), "--child", name,
                   "--record", str(record), "--max-time", str(max_time),
                   f"--example-args={' '.join(example_args)}"]  # '=': args may start with '-'
        if not numpy_compat:
            command.append("--no-numpy-compat")
        before = os.times()
        try:
            done = subprocess.run(command, cwd=checkout, env=env, input=STDIN_LINES,
                                  capture_output=True, text=True, timeout=timeout)
            stderr, row["exit_code"] = done.stderr, done.returncode
        except subprocess.TimeoutExpired as expired:
            stderr = (expired.stderr or b"").decode(errors="replace") if isinstance(
                expired.stderr, bytes) else (expired.stderr or "")
            row["exit_code"] = None
            row["killed_after_s"] = timeout
        after = os.times()
        row["child_cpu_s"] = round((after.children_user - before.children_user)
                                   + (after.children_system - before.children_system), 3)
        runs = json.loads(record.read_text())["runs"] if record.exists() else []
    first: dict[str, Any] = runs[0] if runs else {}
    if runs:
        row.update({k: v for k, v in first.items() if k != "plan"})
        row["plan_length"] = len(first.get("plan", []))
        row["solves"] = len(runs)
    if row["exit_code"] not in (0, None) or not runs:
        reason = _error_line(stderr)
        if not runs or first.get("solve_s") is None:
            row["error"] = reason or "main() never called solve"
        else:
            row["after_solve"] = reason  # the script failed after its solve (display, ...)
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkout", type=Path, nargs="?",
                        help="a PDDLStream checkout (git clone)")
    parser.add_argument("--max-time", type=float, default=60.0)
    parser.add_argument("--only", default="", help="comma-separated example paths (prefixes)")
    parser.add_argument("--example-args", default="",
                        help="command line given to every example, e.g. '-n 4 -p blocked'")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--no-numpy-compat", action="store_true",
                        help="run without the runner's NumPy-1 names (numpy as installed)")
    parser.add_argument("--child", metavar="MODULE", help=argparse.SUPPRESS)
    parser.add_argument("--record", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        return child(args.child, args.example_args.split(), args.max_time, args.record,
                     not args.no_numpy_compat)
    if args.checkout is None:
        parser.error("the checkout is required")
    checkout = args.checkout.resolve()
    if not (checkout / "examples").is_dir():
        print(f"no PDDLStream checkout at {checkout} (no examples/ folder): skipped")
        return 0
    only = [o for o in args.only.split(",") if o]
    rows = []
    for path in example_scripts(checkout):
        relative = str(path.relative_to(checkout / "examples"))
        if only and not any(relative.startswith(prefix) for prefix in only):
            continue
        rows.append(run_example(checkout, path, args.max_time, args.example_args.split(),
                                not args.no_numpy_compat))
        row = rows[-1]
        print(f"{row['example']:<40} loaded={row['loaded']!s:<5} solved={row['solved']!s:<5} "
              f"load={row.get('load_s', float('nan')):.3f}s "
              f"solve={row.get('solve_s', float('nan')):.3f}s "
              f"cpu={row.get('cpu_s', float('nan')):.2f}s "
              f"exit={row['exit_code']} {row.get('status', '')} "
              f"{row.get('error', '')[:110]}", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"checkout": str(checkout), "max_time": args.max_time,
                                    "runner": "ltamp_cli.pddlstream.run (alias, --force)",
                                    "numpy_compat": not args.no_numpy_compat,
                                    "examples": rows}, indent=2, default=str))
    print(f"{sum(r['loaded'] for r in rows)}/{len(rows)} loaded, "
          f"{sum(r['solved'] for r in rows)}/{len(rows)} solved; wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

