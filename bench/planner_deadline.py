"""How late solves return past ``max_time`` (issue #19's bound: ``max_time + 1 s``), for
two versions of the code run alternately under the same machine load.

Each run is one :func:`ltamp_cli.planner.api.solve` of a hidden-suite problem
(``bench/problems/hidden19``, adaptive, the problem's planner options) in a fresh child
process that imports the planner from the given source tree, so that runs share no
memory, collector state or background thread. The child reports the wall time from the
call to its return, the CPU time, and every garbage collection that was running at or
after the deadline (``gc.callbacks``). Runs of the versions alternate (before, after,
before, ...), so both see the same load; the load average is recorded per run.

    OMP_NUM_THREADS=1 nice -n 5 .venv/bin/python bench/planner_deadline.py \\
        --tree before=/tmp/ltamp-main --tree after=. --max-time 15 --seeds 5 \\
        [--problems hidden_robots2_4,...] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
SUITE = REPO / "bench" / "problems" / "hidden19"
BIG_PROBLEMS = ("hidden_robots2_4", "hidden_handoff_2", "hidden_clutter_12")
OVERRUN_TOLERANCE_S = 1.0
DEFAULT_OUT = REPO / "bench" / "results" / "planner_deadline.json"

# The child's program: argv = problem path, seed, max_time. Prints one JSON line.
CHILD = r"""
import dataclasses, gc, json, os, sys, threading, time
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.threads import use_one_thread

use_one_thread()
path, seed, max_time = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
problem = load_problem(path)
known = {f.name for f in dataclasses.fields(PlannerConfig)}
options = {k: v for k, v in problem.planner_options.items() if k in known}
options.update(algorithm="adaptive", seed=seed, max_time=max_time, statistics_dir=None)
collections = []
began = {}
def record(phase, info):
    now = time.perf_counter()
    if phase == "start":
        began[threading.get_ident()] = now
    else:
        collections.append((began.pop(threading.get_ident(), now), now, info["generation"],
                            threading.current_thread().name))
gc.callbacks.append(record)
cpu = time.process_time()
start = time.perf_counter()
result = solve(problem, PlannerConfig(**options))
returned = time.perf_counter()
cpu = time.process_time() - cpu
deadline = start + max_time
late_gc = [(round(b - deadline, 3), round(e - b, 3), g, t) for b, e, g, t in collections
           if e > deadline and b < returned]
print(json.dumps({"status": result.status, "wall_s": returned - start,
                  "late_s": returned - deadline, "cpu_s": cpu,
                  "collections": len(collections),
                  "longest_collection_s": max((e - b for b, e, _, _ in collections),
                                              default=0.0),
                  "collections_past_deadline": late_gc,
                  "stopped_in": result.diagnostics.get("stopped_in")}))
"""


def run_child(tree: Path, problem: str, seed: int, max_time: float,
              suite: Path = SUITE) -> dict[str, Any]:
    """One solve of ``suite/problem.yaml`` in a child process importing the planner from
    ``tree``."""
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as scratch:
        done = subprocess.run(
            [sys.executable, "-c", CHILD, str(suite / f"{problem}.yaml"), str(seed),
             str(max_time)], capture_output=True, text=True, cwd=scratch,
            timeout=max_time + 300,
            env={**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1",
                 "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"})
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if not lines:
        return {"status": "error", "returncode": done.returncode,
                "stderr": done.stderr.strip()[-2000:], "late_s": None}
    row: dict[str, Any] = json.loads(lines[-1])
    row["load_before"] = load_before
    row["load_after"] = os.getloadavg()[0]
    return row


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Return-time distribution (seconds past ``max_time``) of one version's runs."""
    late = sorted(r["late_s"] for r in rows if r.get("late_s") is not None)
    if not late:
        return {"runs": len(rows), "valid": 0}
    quartiles = (statistics.quantiles(late, n=4, method="inclusive") if len(late) > 1
                 else [late[0]] * 3)
    return {"runs": len(rows), "valid": len(late), "min_late_s": late[0],
            "q1_late_s": quartiles[0], "median_late_s": statistics.median(late),
            "q3_late_s": quartiles[2], "max_late_s": late[-1],
            "over_bound": sum(value > OVERRUN_TOLERANCE_S for value in late),
            "runs_with_collection_past_deadline": sum(
                bool(r.get("collections_past_deadline")) for r in rows),
            "median_cpu_s": statistics.median(r["cpu_s"] for r in rows if "cpu_s" in r)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tree", action="append", required=True,
                        help="LABEL=PATH of a source tree (repeat; runs alternate)")
    parser.add_argument("--problems", default=",".join(BIG_PROBLEMS))
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--max-time", type=float, action="append")
    parser.add_argument("--suite", type=Path, default=SUITE,
                        help="folder of the problems (e.g. problems/examples: solved "
                        "problems, to compare CPU time)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args()
    trees = dict(entry.split("=", 1) for entry in args.tree)
    max_times = args.max_time or [15.0]
    rows: list[dict[str, Any]] = []
    for max_time in max_times:
        for problem in args.problems.split(","):
            for seed in range(args.seeds):
                for label, tree in trees.items():
                    row = run_child(Path(tree).resolve(), problem, seed, max_time,
                                    args.suite.resolve())
                    row.update(version=label, problem=problem, seed=seed, max_time=max_time)
                    rows.append(row)
                    late = row.get("late_s")
                    print(f"{label:8s} {problem:20s} seed {seed} max_time {max_time:g}: "
                          f"{row['status']:8s} late "
                          f"{'error' if late is None else f'{late:+.3f} s'} "
                          f"cpu {row.get('cpu_s', float('nan')):.2f} s "
                          f"load {row.get('load_before', 0):.1f}", flush=True)
    summary = {label: summarise([r for r in rows if r["version"] == label])
               for label in trees}
    print(f"\n{'version':8s} {'runs':>4s} {'min':>7s} {'q1':>7s} {'median':>7s} {'q3':>7s} "
          f"{'max':>7s} {'>+1s':>5s} {'gc late':>7s}")
    for label, row in summary.items():
        if not row.get("valid"):
            print(f"{label:8s} {row['runs']:4d}  (no valid run)")
            continue
        print(f"{label:8s} {row['runs']:4d} {row['min_late_s']:+7.3f} {row['q1_late_s']:+7.3f} "
              f"{row['median_late_s']:+7.3f} {row['q3_late_s']:+7.3f} {row['max_late_s']:+7.3f} "
              f"{row['over_bound']:5d} {row['runs_with_collection_past_deadline']:7d}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"trees": trees, "max_times": max_times,
                                    "summary": summary, "runs": rows,
                                    "cpu_count": os.cpu_count(),
                                    "finished": time.strftime("%Y-%m-%dT%H:%M:%SZ",
                                                              time.gmtime())},
                                   indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
