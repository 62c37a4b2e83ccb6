"""Fast Downward vs in-process discrete search: every example × algorithm × search × seed.

Each run is one :func:`ltamp_cli.planner.api.solve` call on an already loaded problem with
``PlannerConfig.search`` set to an in-process engine (``ff``, the default; ``lazy-greedy``;
``wastar``) or a Fast Downward one (``fd``, ``fd-wastar``: translator and ``downward``
subprocesses per discrete search). Every plan is checked by the independent validator.
Reports per (example, algorithm, search): solved / timeouts, plans validated, median wall
time of the solve, median time inside discrete searches and per search call, median cost.
No targets: ``--search fd`` is an optional backend; the table is for choosing one.

    OMP_NUM_THREADS=1 .venv/bin/python bench/fd_search.py [--seeds 3] [--max-time 30]
        [--examples a,b] [--algorithms incremental,focused]
        [--searches ff,lazy-greedy,wastar,fd,fd-wastar] [--out bench/results/fd_search.json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from tqdm import tqdm

from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import ALGORITHMS, PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import PlanningProblem, load_problem
from ltamp_cli.planner.validate import validate_plan

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = REPO / "problems" / "examples"
DEFAULT_OUT = REPO / "bench" / "results" / "fd_search.json"
SEARCHES = ("ff", "lazy-greedy", "wastar", "fd", "fd-wastar")


def run_one(problem: PlanningProblem, algorithm: str, search: str, seed: int,
            max_time: float) -> dict[str, Any]:
    config = PlannerConfig(algorithm=algorithm, search=search, seed=seed, max_time=max_time)
    start = time.perf_counter()
    result = solve(problem, config)
    wall = time.perf_counter() - start
    searches = int(result.stats.get("searches", 0))
    row: dict[str, Any] = {
        "algorithm": algorithm, "search": search, "seed": seed, "status": result.status,
        "wall_s": wall, "search_s": float(result.stats.get("search_time_s", 0.0)),
        "searches": searches, "cost": result.cost if result.solved else None,
        "length": len(result.plan) if result.plan is not None else None,
        "valid": None, "errors": []}
    if result.solved:
        # As in bench/planner.py: certificates list only direct producers of plan facts.
        report = validate_plan(problem, result, check_stream_domains=False)
        row["valid"] = report.valid
        row["errors"] = list(report.errors[:3])
    return row


def summarise(example: str, algorithm: str, search: str, rows: list[dict[str, Any]]
              ) -> dict[str, Any]:
    costs = [r["cost"] for r in rows if r["cost"] is not None]
    per_call = [r["search_s"] / r["searches"] for r in rows if r["searches"]]
    return {
        "example": example, "algorithm": algorithm, "search": search, "runs": len(rows),
        "solved": sum(r["status"] == "solved" for r in rows),
        "timeouts": sum(r["status"] == "timeout" for r in rows),
        "valid": sum(bool(r["valid"]) for r in rows),
        "median_wall_s": statistics.median(r["wall_s"] for r in rows),
        "max_wall_s": max(r["wall_s"] for r in rows),
        "median_search_s": statistics.median(r["search_s"] for r in rows),
        "median_per_search_s": statistics.median(per_call) if per_call else None,
        "median_cost": statistics.median(costs) if costs else None,
    }


def print_table(summary: list[dict[str, Any]], out: Any = sys.stdout) -> None:
    header = (f"{'example':<21} {'algorithm':<11} {'search':<11} {'solved':>6} {'t/o':>3} "
              f"{'valid':>5} {'median s':>9} {'max s':>7} {'search s':>9} {'per call':>9} "
              f"{'cost':>8}")
    print(header, file=out)
    print("-" * len(header), file=out)
    for row in summary:
        cost = "-" if row["median_cost"] is None else f"{row['median_cost']:.4g}"
        per_call = ("-" if row["median_per_search_s"] is None
                    else f"{row['median_per_search_s']:.4f}")
        print(f"{row['example']:<21} {row['algorithm']:<11} {row['search']:<11} "
              f"{row['solved']:>3}/{row['runs']:<2} {row['timeouts']:>3} {row['valid']:>5} "
              f"{row['median_wall_s']:>9.3f} {row['max_wall_s']:>7.2f} "
              f"{row['median_search_s']:>9.3f} {per_call:>9} {cost:>8}", file=out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--examples", default="",
                        help="comma-separated example names (default: every problems/examples"
                             "/*.yaml)")
    parser.add_argument("--algorithms", default=",".join(ALGORITHMS))
    parser.add_argument("--searches", default=",".join(SEARCHES))
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--max-time", type=float, default=30.0,
                        help="time limit per solve in seconds (a timeout counts as a run)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args(argv)

    names = ([n for n in args.examples.split(",") if n] if args.examples
             else sorted(p.stem for p in EXAMPLES.glob("*.yaml")))
    algorithms = [a for a in args.algorithms.split(",") if a]
    searches = [s for s in args.searches.split(",") if s]
    runs: list[dict[str, Any]] = []
    summary: list[dict[str, Any]] = []
    skipped: dict[str, str] = {}
    progress = tqdm(total=len(names) * len(algorithms) * len(searches) * args.seeds,
                    file=sys.stderr, desc="fd_search", disable=not sys.stderr.isatty())
    for name in names:
        problem = load_problem(EXAMPLES / f"{name}.yaml")
        for algorithm in algorithms:
            for search in searches:
                rows = []
                for seed in range(args.seeds):
                    progress.set_postfix_str(f"{name} {algorithm} {search} seed {seed}")
                    progress.update()
                    if search in skipped:
                        continue
                    try:
                        row = run_one(problem, algorithm, search, seed, args.max_time)
                    except InputError as error:  # e.g. the optional 'fd' extra is missing
                        skipped[search] = str(error)
                        continue
                    rows.append(row)
                    runs.append({"example": name, **row})
                if rows:
                    summary.append(summarise(name, algorithm, search, rows))
    progress.close()

    print_table(summary)
    for search, reason in skipped.items():
        print(f"SKIPPED {search}: {reason}")
    for row in (r for r in runs if r["valid"] is False):
        print(f"INVALID PLAN: {row['example']} / {row['algorithm']} / {row['search']} / "
              f"seed {row['seed']}: {'; '.join(row['errors'])}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "benchmark": "fd_search", "seeds": args.seeds, "max_time_s": args.max_time,
        "summary": summary, "skipped": skipped, "runs": runs,
    }, indent=2) + "\n")
    print(f"\nwrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
