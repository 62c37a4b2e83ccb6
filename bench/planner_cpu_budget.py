"""Solves problems within a budget of **process CPU seconds** instead of wall seconds, so
that a loaded machine changes how long a run takes but not what it finds (issue #19's
crowded problems: ``hidden_clutter_10``, ``hidden_clutter_12``, ``hidden_stack_4``).

The planner's own clock check (``PlannerState.timed_out``) also answers "timed out" once
the process has used ``--budget`` CPU seconds since the solve started; a search already
running finishes first, so a run may end a little past the budget. The wall limit is
``--max-time`` (default one hour). Every plan is validated (``bench/planner.py``'s run).

    python bench/planner_cpu_budget.py [--problems hidden_clutter_10,...] [--seeds 0-4]
        [--algorithms adaptive] [--budget 15] [--out FILE.json]

Prints a row per run and writes JSON (rows plus the load average at each run).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import planner as bench_planner
from planner import run_one

from ltamp_cli.planner.algorithms import common
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.threads import use_one_thread

REPO = Path(__file__).resolve().parent.parent
SUITE = REPO / "bench" / "problems" / "hidden19"
PROBLEMS = ("hidden_clutter_10", "hidden_clutter_12", "hidden_stack_4")


@contextlib.contextmanager
def cpu_budget(seconds: float) -> Iterator[None]:
    """``PlannerState.timed_out`` is also true once this process used ``seconds`` of CPU
    after the state was made (its ``start_time``): restored on exit."""
    original = common.PlannerState.timed_out
    started: dict[int, float] = {}

    def timed_out(state: common.PlannerState) -> bool:
        first = started.setdefault(id(state), time.process_time())
        return original(state) or time.process_time() - first > seconds

    common.PlannerState.timed_out = timed_out  # type: ignore[method-assign]
    try:
        yield
    finally:
        common.PlannerState.timed_out = original  # type: ignore[method-assign]


def seeds_of(text: str) -> list[int]:
    """``"0-4"`` or ``"0,3,5"`` as a list of seeds."""
    if "-" in text:
        low, high = text.split("-")
        return list(range(int(low), int(high) + 1))
    return [int(part) for part in text.split(",")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--problems", default=",".join(PROBLEMS))
    parser.add_argument("--seeds", default="0-4")
    parser.add_argument("--algorithms", default="adaptive")
    parser.add_argument("--budget", type=float, default=15.0, help="CPU seconds per solve")
    parser.add_argument("--max-time", type=float, default=3600.0, help="wall seconds")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    if not args.budget > 0:
        print(f"--budget: expected a positive number of seconds, got {args.budget}",
              file=sys.stderr)
        raise SystemExit(2)
    use_one_thread()
    # The last solve's own statistics (run_one keeps only its work counts).
    last: dict[str, Any] = {}
    plain_solve = bench_planner.solve

    def solve(*args: Any, **kwargs: Any) -> Any:
        result = plain_solve(*args, **kwargs)
        last.update(searches=result.stats.get("searches"), parked=result.stats.get("parked"),
                    solved_by=result.stats.get("solved_by"))
        return result

    bench_planner.solve = solve
    rows: list[dict[str, Any]] = []
    print(f"{'problem':<20} {'algorithm':<9} {'seed':>4} {'status':<9} {'cpu s':>7} "
          f"{'searches':>8} {'calls':>7} {'facts':>9} {'grounded':>9} {'len':>4} {'valid':>5} "
          f"{'load':>5}",
          flush=True)
    for name in args.problems.split(","):
        problem = load_problem(SUITE / f"{name}.yaml")
        for algorithm in args.algorithms.split(","):
            for seed in seeds_of(args.seeds):
                with cpu_budget(args.budget):
                    row = run_one(problem, algorithm, seed, args.max_time)
                work = row.get("work") or {}
                row.update(problem=name, budget_cpu_s=args.budget, load=os.getloadavg()[0],
                           **last)
                rows.append(row)
                print(f"{name:<20} {algorithm:<9} {seed:>4} {row['status']:<9} "
                      f"{row['cpu_s']:>7.2f} {row['searches']!s:>8} {work.get('calls', '-'):>7} "
                      f"{work.get('facts', '-'):>9} {work.get('grounded', '-'):>9} "
                      f"{row['length'] or '-':>4} {row['valid']!s:>5} {row['load']:>5.1f} "
                      f"{'parked ' + str(row['parked']['parked']) if row['parked'] else ''}",
                      flush=True)
                args.out.write_text(json.dumps({"budget_cpu_s": args.budget, "runs": rows},
                                               indent=1))
    solved = sum(r["status"] == "solved" for r in rows)
    print(f"solved {solved}/{len(rows)}")


if __name__ == "__main__":
    main()
