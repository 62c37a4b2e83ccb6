"""One solve of a hidden-suite problem by PDDLStream itself, in a child process whose
``sys.path`` holds a PDDLStream checkout (``bench/planner_hidden.py --pddlstream``).
Prints one JSON line: status, plan length, cost, CPU seconds of this process inside
``solve`` and of the Fast Downward subprocesses it ran.

    PYTHONPATH=CHECKOUT python run_pddlstream.py PROBLEM.yaml SEED MAX_TIME

PDDLStream writes ``temp/`` and ``statistics/`` into its working directory: run it in a
scratch folder (the bench does).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import random
import resource
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pddlstream_problem import pddlstream_problem

# PDS_VERBOSE=1: PDDLStream prints its iterations (to the captured log, dropped).
VERBOSE = os.environ.get("PDS_VERBOSE") == "1"
# The settings of PDDLStream's examples/continuous_tamp/run.py (the reference).
SETTINGS = {"planner": "max-astar", "max_planner_time": 10, "unit_efforts": True,
            "effort_weight": 1.0, "search_sample_ratio": 1, "max_iterations": float("inf")}
# PDS_SETTINGS=default: ``solve``'s own defaults instead (only the algorithm is named).
PRESETS = {"example": SETTINGS, "default": {}}


def _counted(wrap: Callable[..., Any], name: str, calls: dict[str, int]) -> Callable[..., Any]:
    """``wrap`` (``from_gen_fn`` etc.) of a function that counts its calls in ``calls``."""
    def wrapper(fn: Callable[..., Any]) -> Any:
        def counted(*args: Any) -> Any:
            calls[name] = calls.get(name, 0) + 1
            return fn(*args)
        return wrap(counted)
    return wrapper


def main() -> None:
    from pddlstream.algorithms.meta import solve
    from pddlstream.language.constants import PDDLProblem
    from pddlstream.language.generator import from_fn, from_gen_fn, from_test

    path, seed, max_time = Path(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
    random.seed(seed)
    np.random.seed(seed)
    settings = PRESETS[os.environ.get("PDS_SETTINGS", "example")]
    calls: dict[str, int] = {}
    problem, options = pddlstream_problem(path, seed, {
        "PDDLProblem": PDDLProblem, "from_gen_fn": _counted(from_gen_fn, "gen", calls),
        "from_fn": _counted(from_fn, "fn", calls), "from_test": _counted(from_test, "test", calls)})
    cpu = time.process_time()
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    log = io.StringIO()
    with contextlib.redirect_stdout(log):
        solution = solve(problem, algorithm="adaptive", max_time=max_time,
                         unit_costs=bool(options.get("unit_costs", False)), verbose=VERBOSE,
                         **settings)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    plan, cost = solution.plan, solution.cost
    print(json.dumps({
        "status": "solved" if plan is not None else "unsolved",
        "length": None if plan is None else len(plan),
        "cost": None if plan is None else float(cost),
        "cpu_s": time.process_time() - cpu,
        "fd_cpu_s": (after.ru_utime + after.ru_stime) - (children.ru_utime + children.ru_stime),
        "wall_s": time.perf_counter() - wall,
        "calls": calls,
    }))


if __name__ == "__main__":
    main()
