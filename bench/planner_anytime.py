"""Anytime solves (``success_cost``) with the interleaved incremental member: how many times
the bindings' ``make_streams`` ran, how many rounds, the cost reached and the CPU used.

Each (problem, algorithm, seed) is one :func:`ltamp_cli.planner.api.solve` with
``success_cost`` (default 0: improve until ``max_time``) in this process; the problem's
``make_streams`` is wrapped to count its calls (one for the optimistic member, one for the
interleaved member when it ran: issue #19 made one member per solve, where every round made
its own). CPU seconds are this process's (``time.process_time``); the machine's load
average is recorded per row, since a solve bounded by ``max_time`` gets less CPU under load.

    OMP_NUM_THREADS=1 .venv/bin/python bench/planner_anytime.py \\
        --problems problems/examples/tamp2d_uniform_tight_8.yaml --seeds 3 --max-time 10 \\
        --out bench/results/planner_anytime.json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import PlanningProblem, load_problem
from ltamp_cli.threads import use_one_thread

REPO = Path(__file__).resolve().parent.parent
DEFAULT_PROBLEMS = ("problems/examples/tamp2d_4blocks.yaml",
                    "problems/examples/tamp2d_uniform_tight_8.yaml",
                    "bench/problems/hidden19/hidden_chain_4.yaml")


def counted(problem: PlanningProblem, made: list[int]) -> PlanningProblem:
    """``problem`` whose ``make_streams`` appends to ``made`` at every call."""
    factory = problem.streams_factory
    assert factory is not None

    def make_streams(world: Any, rng: Any) -> Any:
        made.append(1)
        return factory(world, rng)

    return replace(problem, streams_factory=make_streams)


def run_one(path: Path, algorithm: str, seed: int, max_time: float,
            success_cost: float) -> dict[str, Any]:
    """One anytime solve's row."""
    made: list[int] = []
    problem = counted(load_problem(path), made)
    start = time.process_time()
    result = solve(problem, PlannerConfig(algorithm=algorithm, seed=seed, max_time=max_time,
                                          success_cost=success_cost))
    member = result.stats.get("interleaved", {})
    return {"problem": path.stem, "algorithm": algorithm, "seed": seed,
            "status": result.status, "cost": result.cost,
            "anytime_costs": result.stats.get("anytime_costs", []),
            "make_streams": len(made), "cpu_s": round(time.process_time() - start, 4),
            "member_work_units": member.get("work_units"),
            "member_rounds": member.get("rounds"),
            "member_stream_calls": member.get("stream_calls"),
            "load_average": os.getloadavg()[0]}


def table(rows: list[dict[str, Any]]) -> str:
    """Per (problem, algorithm): solves, median rounds, make_streams calls, cost, CPU."""
    lines = ["| problem | alg | solved | median rounds | make_streams (max) | median cost "
             "| median CPU s |", "|---|---|---|---|---|---|---|"]
    keys = dict.fromkeys((r["problem"], r["algorithm"]) for r in rows)
    for problem, algorithm in keys:
        group = [r for r in rows if (r["problem"], r["algorithm"]) == (problem, algorithm)]
        solved = [r for r in group if r["status"] == "solved"]
        rounds = statistics.median(len(r["anytime_costs"]) for r in group)
        cost = statistics.median(r["cost"] for r in solved) if solved else float("inf")
        lines.append(f"| {problem} | {algorithm} | {len(solved)}/{len(group)} | {rounds:g} "
                     f"| {max(r['make_streams'] for r in group)} | {cost:.2f} "
                     f"| {statistics.median(r['cpu_s'] for r in group):.3f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problems", default=",".join(DEFAULT_PROBLEMS))
    parser.add_argument("--algorithms", default="adaptive,binding")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--max-time", type=float, default=10.0)
    parser.add_argument("--success-cost", type=float, default=0.0)
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results"
                        / "planner_anytime.json")
    args = parser.parse_args(argv)
    use_one_thread()
    rows = [run_one(REPO / problem, algorithm, seed, args.max_time, args.success_cost)
            for problem in args.problems.split(",")
            for algorithm in args.algorithms.split(",")
            for seed in range(args.seeds)]
    print(table(rows))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(rows, indent=1))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
