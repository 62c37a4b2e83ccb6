"""How well the interleaved incremental member's work units track CPU (issue #19).

The optimistic algorithms and their incremental member take turns by work units
(:func:`ltamp_cli.planner.algorithms.interleave.work_units`: stream calls, facts and ground
actions of searched tasks, evaluated states), never by a clock, so that a seed's plan does
not depend on the machine's load. The units are meant to cost about a microsecond of CPU
each, and about as much for either member (else the share in units is not the intended
share of CPU). This script solves problems with each member alone (an optimistic
algorithm with ``interleave`` off, and ``incremental``), prints CPU seconds, work units
and microseconds of CPU per unit per solve and their medians per algorithm, fits the
weights again by least squares (relative error; for the record, the module's constants
are rounded from such a fit) and writes JSON.

    OMP_NUM_THREADS=1 nice -n 5 .venv/bin/python bench/planner_work_units.py
        [--problems tamp2d_uniform_tight_8,hidden_chain_4,...] [--algorithms adaptive,...]
        [--seeds 3] [--max-time 10] [--out FILE.json]

Problems are named by file stem, looked up in ``problems/examples`` then
``bench/problems/hidden19``. CPU is the process's (``time.process_time``): run it on a
quiet machine or compare ratios, not seconds.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

import numpy as np
from planner import config_for
from scipy.optimize import nnls

from ltamp_cli.planner.algorithms.common import WorkCount
from ltamp_cli.planner.algorithms.interleave import work_units
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.threads import use_one_thread

REPO = Path(__file__).resolve().parent.parent
FOLDERS = (REPO / "problems" / "examples", REPO / "bench" / "problems" / "hidden19")
DEFAULT_PROBLEMS = ("tamp2d_uniform_tight_4,tamp2d_uniform_tight_8,tamp2d_uniform_blocked_8,"
                    "kitchen_symbolic,tamp2d_4blocks,hidden_chain_4,hidden_handoff_2,"
                    "hidden_regions3_4,hidden_obstacles_3")
COUNTS = tuple(f.name for f in fields(WorkCount))


def problem_path(name: str) -> Path:
    for folder in FOLDERS:
        path = folder / f"{name}.yaml"
        if path.exists():
            return path
    raise SystemExit(f"unknown problem {name!r}: no {name}.yaml in "
                     f"{', '.join(str(f) for f in FOLDERS)}")


def run(name: str, algorithm: str, seed: int, max_time: float) -> dict[str, Any]:
    """One solve of member ``algorithm`` alone: CPU seconds and work counts."""
    problem = load_problem(problem_path(name))
    config = replace(config_for(problem, algorithm, seed, max_time, None), interleave=False)
    cpu = time.process_time()
    result = solve(problem, config)
    cpu = time.process_time() - cpu
    work = result.stats.get("work", {})
    units = work_units(WorkCount(**work))
    return {"problem": name, "algorithm": algorithm, "seed": seed, "status": result.status,
            "cpu_s": cpu, "work": work, "units": units,
            "us_per_unit": cpu * 1e6 / units if units else None}


def fit(rows: list[dict[str, Any]]) -> dict[str, float]:
    """Least-squares weights (microseconds per count) of CPU on the counts, relative error,
    solved runs only (a timeout's last step is cut and not counted)."""
    solved = [r for r in rows if r["status"] == "solved"]
    if not solved:
        return {}
    x = np.array([[r["work"].get(k, 0) for k in COUNTS] for r in solved], float)
    y = np.array([r["cpu_s"] for r in solved])
    weight = 1 / np.maximum(y, 0.01)
    coef, _ = nnls(x * weight[:, None], y * weight)
    return {k: round(float(c) * 1e6, 4) for k, c in zip(COUNTS, coef, strict=True)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--problems", default=DEFAULT_PROBLEMS)
    parser.add_argument("--algorithms", default="adaptive,binding,incremental")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--max-time", type=float, default=10.0)
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results"
                        / "planner_work_units.json")
    args = parser.parse_args()
    use_one_thread()
    rows = []
    print(f"{'problem':28s} {'algorithm':11s} seed status   CPU s    units  us/unit")
    for name in args.problems.split(","):
        for algorithm in args.algorithms.split(","):
            for seed in range(args.seeds):
                row = run(name, algorithm, seed, args.max_time)
                rows.append(row)
                ratio = row["us_per_unit"]
                print(f"{name:28s} {algorithm:11s} {seed:4d} {row['status']:8s} "
                      f"{row['cpu_s']:6.3f} {row['units']:8.0f}  "
                      f"{'-' if ratio is None else f'{ratio:.2f}'}", flush=True)
    medians = {}
    for algorithm in args.algorithms.split(","):
        ratios = [r["us_per_unit"] for r in rows
                  if r["algorithm"] == algorithm and r["us_per_unit"] is not None]
        if ratios:
            medians[algorithm] = round(statistics.median(ratios), 3)
            print(f"median us per unit, {algorithm}: {medians[algorithm]:.2f} "
                  f"({len(ratios)} solves)")
    weights = fit(rows)
    print(f"refitted weights (us per count): {weights}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"benchmark": "planner_work_units", "rows": rows,
                                    "median_us_per_unit": medians,
                                    "refitted_weights_us": weights}, indent=1))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
