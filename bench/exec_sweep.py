"""Each shipped problem x each engine that executes it x seeds 0-9: planned? goal holds? (#20).

One resumable sweep over ``problems/kitchen2d/*.yaml`` (executed in Box2D) and
``problems/kitchen3d/*.yaml`` (executed in PyBullet and in SAPIEN). A cell is one
(problem, engine) pair; its seeds are planned with the problem's own planner options (the
seed replaced, ``--max-time`` replacing the wall-clock planning limit: on a loaded machine a
wall-clock limit is a far smaller CPU limit) and the plan executed on the cell's engine,
which checks the goal physically. Every finished seed is appended to the cell's JSONL
cache under ``--cache-dir`` (default ``docs/results/exec3d/sweep``) at once, so a stopped
sweep resumes where it stopped; ``--reuse`` first copies into the caches the rows of earlier
runs that are still valid (``REUSE``: the file each came from is kept in the row's
``source``). Cells run in the order of ``CELLS`` (cheapest first).

A row: planned? (status), planning CPU/wall seconds, the plan's actions, the engine's
execution CPU/wall seconds, whether every step executed, whether the goal holds, the first
failed step (action, error) and the goal facts with their measurements; ``why`` is a
one-line reason for a seed whose goal does not hold. CPU seconds are this process's (one
thread: run with ``OMP_NUM_THREADS=1``).

    nice -n 5 .venv/bin/python bench/exec_sweep.py --max-time 600 --reuse
    .venv/bin/python bench/exec_sweep.py --summarise        # table + JSON from the caches only
    .venv/bin/python bench/exec_sweep.py --only kitchen2d/coffee:box2d --seeds 0 1

The table (problem | engine | planned | goal holds of seeds, Wilson 95 % | median planning
and execution CPU | failures) is printed and written with every row to ``--out`` (default
``docs/results/exec3d/sweep.json``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.learning.metrics import wilson_interval

ROOT = Path(__file__).resolve().parents[1]
PROBLEMS = ROOT / "problems"
RESULTS = ROOT / "docs" / "results" / "exec3d"
SEEDS = tuple(range(10))


@dataclass(frozen=True)
class Cell:
    """One (problem, engine) pair: ``suite`` is ``kitchen2d`` or ``kitchen3d``."""

    suite: str
    problem: str
    engine: str

    @property
    def key(self) -> str:
        return f"{self.suite}/{self.problem}:{self.engine}"

    @property
    def path(self) -> Path:
        return PROBLEMS / self.suite / f"{self.problem}.yaml"

    def cache(self, directory: Path) -> Path:
        return directory / f"{self.suite}_{self.problem}_{self.engine}.jsonl"


#: Cheapest first: all 2D, then the 3D problems on SAPIEN (seconds per execution, coffee
#: ~40 s), then PyBullet (its seeds mostly reused: ``REUSE``; unclog seeds 0-4 re-run at
#: ~60 s CPU each, coffee ~250 s CPU per seed).
CELLS: tuple[Cell, ...] = (
    *(Cell("kitchen2d", name, "box2d") for name in (
        "task1_push_off", "task2_pour_wall", "task3_holder_pour", "fill_and_serve", "coffee")),
    *(Cell("kitchen3d", name, "sapien") for name in (
        "pour_blocked", "wash", "unclog", "push_to_reach", "coffee")),
    *(Cell("kitchen3d", name, "pybullet") for name in (
        "wash", "pour_blocked", "push_to_reach", "unclog", "coffee")),
)

#: Earlier runs (files in ``docs/results/exec3d``) whose rows stand for the current code:
#: cell key -> [(file, seeds taken)]. Left out on purpose: unclog PyBullet seeds 0-4 and
#: coffee SAPIEN seeds 0-1 (``unclog_pybullet.jsonl``, ``coffee_sapien.jsonl``) ran with
#: the 3D scoop model before its bead-bed relabelling (eb2cf2a); the push_to_reach rows
#: before the across-push fix (749fef8); coffee PyBullet's first runs (``coffee_pybullet
#: .jsonl``) on the pre-relabelling scoop model.
REUSE: dict[str, list[tuple[str, tuple[int, ...]]]] = {
    "kitchen3d/coffee:pybullet": [("coffee_pybullet_main.jsonl", SEEDS)],
    "kitchen3d/coffee:sapien": [("coffee_sapien_main.jsonl", (2, 3, 4))],
    "kitchen3d/pour_blocked:pybullet": [("pour_blocked_pybullet.jsonl", SEEDS)],
    "kitchen3d/pour_blocked:sapien": [("pour_blocked_sapien.jsonl", SEEDS)],
    "kitchen3d/wash:pybullet": [("wash_pybullet.jsonl", SEEDS),
                                ("wash_pybullet_main.jsonl", SEEDS)],
    "kitchen3d/unclog:pybullet": [("unclog_pybullet_main.jsonl", SEEDS)],
    "kitchen3d/push_to_reach:pybullet": [("push_to_reach_across.jsonl", SEEDS)],
    "kitchen3d/push_to_reach:sapien": [("push_to_reach_across.jsonl", SEEDS)],
}


def goal_facts(goal: Any) -> list[dict]:
    """The executor's goal facts as a list of ``{"fact", "holds", ...}`` (the 3D executors
    give a list, Box2D a fact -> measurements mapping)."""
    if isinstance(goal, dict):
        return [{"fact": fact, **values} for fact, values in goal.items()]
    return list(goal or [])


def why(engine_row: dict) -> str | None:
    """One line: why the goal does not hold (the first failed step, else the failed goal
    facts with their measurements); ``None`` when it holds."""
    if engine_row.get("goal_holds"):
        return None
    step = engine_row.get("failed_step")
    if step:
        return f"step {step.get('step')} {step.get('action')}: {step.get('error', '?')}"
    failed = [fact for fact in engine_row.get("goal", []) if not fact.get("holds")]
    parts = []
    for fact in failed:
        shown = {k: v for k, v in fact.items() if k not in ("fact", "holds")}
        parts.append(f"{fact.get('fact')} fails {json.dumps(shown, sort_keys=True)[:200]}")
    return "; ".join(parts) or engine_row.get("diagnosis") or "goal does not hold"


def execution_row(report: Any, cpu_s: float, wall_s: float) -> dict:
    """What one execution's report says: times, verdicts, the first failed step, the goal
    facts with their measurements, the executor's diagnosis (Box2D) and skill logs."""
    details = report.details
    failed = [step for step in details.get("steps", []) if not step.get("ok", True)]
    row = {
        "wall_s": wall_s,
        "cpu_s": cpu_s,
        "executed": bool(report.success),
        "goal_holds": bool(report.goal_holds),
        "sim_time_s": details.get("sim_time_s"),
        "failed_step": failed[0] if failed else None,
        "goal": goal_facts(details.get("goal")),
        "diagnosis": details.get("diagnosis"),
        "error": details.get("error"),
        "skill_actions": [
            {k: v for k, v in entry.items() if k in (
                "action", "counts", "spoonful", "left_in_spoon", "stirred", "counts_after",
                "start_xy", "rest_xy", "error_m", "finger_gap_m", "contents")}
            for entry in details.get("log", []) if isinstance(entry, dict)
            and entry.get("action") in ("pour", "scoop", "dump", "stir", "push", "fill")],
    }
    row["why"] = why(row)
    return row


def commit() -> str:
    """The worktree's HEAD (``+dirty`` when tracked files differ from it)."""
    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True,
                              text=True, check=False).stdout.strip()
    head = git("rev-parse", "--short", "HEAD")
    dirty = git("status", "--porcelain", "--untracked-files=no", "--", "ltamp_cli", "domains",
                "models", "problems")
    return head + ("+dirty" if dirty else "")


def read_cache(path: Path) -> dict[int, dict]:
    """seed -> row of a cell's JSONL cache (a later row of a seed replaces an earlier one)."""
    rows: dict[int, dict] = {}
    if path.exists():
        for line in path.read_text().splitlines():
            if line.strip():
                row = json.loads(line)
                rows[int(row["seed"])] = row
    return rows


def append(path: Path, row: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a") as handle:
        handle.write(json.dumps(row) + "\n")


def reuse_rows(cell: Cell, cache: Path) -> int:
    """Copy the still-valid earlier rows of ``cell`` (``REUSE``) whose seed the cache lacks;
    returns how many were copied. An old row executed on both engines is cut to the cell's."""
    have = read_cache(cache)
    copied = 0
    for name, seeds in REUSE.get(cell.key, []):
        for seed, old in read_cache(RESULTS / name).items():
            if seed in have or seed not in seeds or old.get("problem") != cell.problem:
                continue
            if old["status"] == "solved" and cell.engine not in old:
                continue
            row = {k: v for k, v in old.items() if k not in ("pybullet", "sapien")}
            row.update(suite=cell.suite, engine=cell.engine, source=name)
            if old["status"] == "solved":
                engine = dict(old[cell.engine])
                engine["goal"] = goal_facts(engine.get("goal"))
                engine["why"] = why(engine)
                row["execution"] = engine
            have[seed] = row
            append(cache, row)
            copied += 1
    return copied


def run_seed(cell: Cell, seed: int, max_time: float | None) -> dict:
    """Plan ``cell``'s problem with ``seed`` and execute the plan on the cell's engine."""
    from ltamp_cli.backends.execution import execute_plan
    from ltamp_cli.planner.algorithms.common import PlannerConfig
    from ltamp_cli.planner.api import solve
    from ltamp_cli.planner.problem import load_problem

    problem = load_problem(cell.path)
    options = {**problem.planner_options, "seed": seed}
    if max_time is not None:
        options["max_time"] = max_time
    w0, c0 = time.perf_counter(), time.process_time()
    result = solve(problem, PlannerConfig(**options))
    row: dict = {"problem": cell.problem, "suite": cell.suite, "engine": cell.engine,
                 "seed": seed, "status": result.status, "max_time_s": options.get("max_time"),
                 "plan_cpu_s": time.process_time() - c0,
                 "plan_wall_s": time.perf_counter() - w0,
                 "actions": [step.name for step in (result.plan or ())],
                 "commit": commit(), "loadavg": os.getloadavg()[0],
                 "source": "exec_sweep"}
    if result.solved:
        w0, c0 = time.perf_counter(), time.process_time()
        report = execute_plan(cell.engine, problem, result, seed)
        row["execution"] = execution_row(report, time.process_time() - c0,
                                         time.perf_counter() - w0)
    return row


def cell_summary(cell: Cell, rows: dict[int, dict], seeds: tuple[int, ...]) -> dict:
    """Planned and goal-holding counts over the cached ``seeds`` (Wilson 95 % over the seeds
    tried), median planning and execution CPU, and each failure with its reason."""
    tried = [rows[s] for s in seeds if s in rows]
    solved = [r for r in tried if r["status"] == "solved"]
    held = [r for r in solved if r.get("execution", {}).get("goal_holds")]

    def median(values: list[float]) -> float | None:
        return float(np.median(values)) if values else None

    return {
        "cell": cell.key, "suite": cell.suite, "problem": cell.problem, "engine": cell.engine,
        "seeds": [r["seed"] for r in tried],
        "planned": len(solved),
        "goal_holds": len(held),
        "goal_holds_wilson95": list(wilson_interval(len(held), len(tried))),
        "plan_cpu_median_s": median([r["plan_cpu_s"] for r in tried if "plan_cpu_s" in r]),
        "exec_cpu_median_s": median([r["execution"]["cpu_s"] for r in solved
                                     if "cpu_s" in r.get("execution", {})]),
        "sources": sorted({r.get("source", "?") for r in tried}),
        "failures": [{"seed": r["seed"], "status": r["status"],
                      "why": (r.get("execution") or {}).get("why")
                      if r["status"] == "solved" else f"not planned ({r['status']})"}
                     for r in tried if r not in held],
    }


def _seconds(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.2f} s" if value < 1.0 else f"{value:.1f} s"


def print_table(summaries: list[dict]) -> None:
    print("| problem | engine | planned | goal holds (Wilson 95 %) | plan CPU median | "
          "exec CPU median | failures |")
    print("|---|---|---|---|---|---|---|")
    for s in summaries:
        n = len(s["seeds"])
        low, high = s["goal_holds_wilson95"]
        plan, run = (_seconds(s["plan_cpu_median_s"]), _seconds(s["exec_cpu_median_s"]))
        fails = "; ".join(f"seed {f['seed']}: {f['why']}" for f in s["failures"]) or "none"
        print(f"| {s['suite'][-2:]} {s['problem']} | {s['engine']} | {s['planned']}/{n} | "
              f"{s['goal_holds']}/{n} ({low:.2f}-{high:.2f}) | {plan} | {run} | {fails} |")


def parse_cells(only: list[str] | None) -> list[Cell]:
    if not only:
        return list(CELLS)
    known = {cell.key: cell for cell in CELLS}
    unknown = [key for key in only if key not in known]
    if unknown:
        print(f"error: --only: unknown cell {unknown[0]!r} (known: {', '.join(known)})",
              file=sys.stderr)
        raise SystemExit(2)
    return [known[key] for key in only]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", metavar="SUITE/PROBLEM:ENGINE",
                        help="cells to run (default: all, in CELLS order)")
    parser.add_argument("--seeds", nargs="+", type=int, default=list(SEEDS))
    parser.add_argument("--max-time", type=float, default=None,
                        help="planning wall-clock limit (s) instead of the problem's")
    parser.add_argument("--cache-dir", type=Path, default=RESULTS / "sweep")
    parser.add_argument("--out", type=Path, default=RESULTS / "sweep.json")
    parser.add_argument("--reuse", action="store_true",
                        help="first copy the still-valid rows of earlier runs (REUSE)")
    parser.add_argument("--rerun", action="store_true",
                        help="run the --seeds of the --only cells again (appended rows win)")
    parser.add_argument("--summarise", action="store_true",
                        help="no planning: tabulate the caches")
    args = parser.parse_args()
    if args.max_time is not None and not (args.max_time > 0 and math.isfinite(args.max_time)):
        parser.error("--max-time must be a positive number of seconds")
    if any(seed < 0 for seed in args.seeds):
        parser.error("--seeds must be >= 0")
    cells = parse_cells(args.only)
    seeds = tuple(sorted(set(args.seeds)))
    if args.reuse:
        for cell in cells:
            copied = reuse_rows(cell, cell.cache(args.cache_dir))
            if copied:
                print(f"{cell.key}: {copied} earlier rows reused", flush=True)
    if not args.summarise:
        for cell in cells:
            cache = cell.cache(args.cache_dir)
            done = {} if args.rerun else read_cache(cache)
            for seed in seeds:
                if seed in done:
                    continue
                row = run_seed(cell, seed, args.max_time)
                append(cache, row)
                ex = row.get("execution") or {}
                print(f"{cell.key} seed {seed}: {row['status']}, plan {row['plan_cpu_s']:.1f} s "
                      f"CPU, exec {ex.get('cpu_s', 0.0):.1f} s CPU, goal "
                      f"{'holds' if ex.get('goal_holds') else 'fails: ' + str(ex.get('why'))}",
                      flush=True)
    summaries = [cell_summary(c, read_cache(c.cache(args.cache_dir)), seeds) for c in cells]
    print_table(summaries)
    payload = {"benchmark": "exec_sweep", "python": platform.python_version(),
               "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
               "max_time_s": args.max_time, "seeds": list(seeds), "commit": commit(),
               "cells": summaries,
               "rows": {c.key: [read_cache(c.cache(args.cache_dir))[s] for s in seeds
                                if s in read_cache(c.cache(args.cache_dir))] for c in cells}}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(payload, indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
