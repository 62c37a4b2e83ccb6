"""Where a solve's CPU time goes, per discrete search and per phase.

Solves one example problem (cold stream history, the problem file's planner options) for
each seed in this thread, with timers wrapped around the planner's phases: optimistic
evaluation, grounding (``ground_task`` and the solve's ``GroundingCache``), fluent contexts,
task encoding, state vectors (axioms), the FF heuristic's construction and evaluations, the
rest of the search engine, guess checks, plan post-processing and binding processing. Prints one
row per discrete search (what kind of search, task size, expansions, evaluations, whether
the guessed plan was followed, grounding and search CPU seconds) and a table of phase
totals, and writes both as JSON. Timers are thread CPU seconds (``time.thread_time``); the
wrappers add a few percent, so compare runs of this script with each other, not with
``bench/planner.py``.

    OMP_NUM_THREADS=1 .venv/bin/python bench/planner_profile.py [--example kitchen_fluent]
        [--algorithm adaptive] [--seeds 0-9] [--out bench/results/planner_profile.json]
        [--incremental-grounding] [--search lazy-greedy]
"""

from __future__ import annotations

import argparse
import gc
import json
import statistics
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from planner import config_for

from ltamp_cli.planner.algorithms import common, skeletons
from ltamp_cli.planner.api import _solve
from ltamp_cli.planner.gc_pacing import SOLVE_GC_THRESHOLD0
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.search import engine, heuristic, incremental, solve
from ltamp_cli.planner.search.task import Task
from ltamp_cli.planner.watchdog import CallTracker
from ltamp_cli.threads import use_one_thread

REPO = Path(__file__).resolve().parent.parent
DEFAULT_OUT = REPO / "bench" / "results" / "planner_profile.json"
# (module, attribute, phase name): functions whose thread CPU time is summed per phase.
PHASES = (
    (skeletons, "optimistic_evaluation", "optimistic evaluation"),
    (skeletons, "evaluate_eager", "eager streams"),
    (skeletons, "_process", "binding processing"),
    (solve, "ground_task", "grounding"),
    (incremental.GroundingCache, "ground", "grounding"),
    (solve, "require_fluent_contexts", "fluent contexts"),
    (solve, "forbid_contexts", "fluent contexts"),
    (engine, "follow_plan", "guess check"),
    (engine, "_search", "search engine (incl. heuristic)"),
    (engine, "eliminate_redundant_actions", "post-processing: elimination"),
    (engine, "bridge_detours", "post-processing: bridging"),
)


def parse_seeds(text: str) -> list[int]:
    """``"0-9"`` or ``"0,3,5"`` -> seeds."""
    if "-" in text:
        low, high = text.split("-", 1)
        return list(range(int(low), int(high) + 1))
    return [int(s) for s in text.split(",") if s]


@contextmanager
def wrapped(phases: Counter, searches: list[dict[str, Any]]) -> Iterator[None]:
    """Install the timers (restored on exit)."""
    saved: list[tuple[Any, str, Any]] = []

    def timer(function: Callable[..., Any], name: str) -> Callable[..., Any]:
        def run(*args: Any, **kwargs: Any) -> Any:
            start = time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                phases[name] += time.thread_time() - start
        return run

    def patch(owner: Any, attribute: str, replacement: Any) -> None:
        saved.append((owner, attribute, getattr(owner, attribute)))
        setattr(owner, attribute, replacement)

    for module, attribute, name in PHASES:
        patch(module, attribute, timer(getattr(module, attribute), name))
    patch(heuristic.FFHeuristic, "_evaluate",
          timer(heuristic.FFHeuristic._evaluate, "heuristic evaluations"))
    patch(Task, "__init__", timer(Task.__init__, "task encoding"))
    patch(heuristic.FFHeuristic, "__init__",
          timer(heuristic.FFHeuristic.__init__, "heuristic construction"))
    patch(Task, "_compute_vector", timer(Task._compute_vector, "state vectors (axioms)"))
    search = common.PlannerState.search

    def logged(state: Any, init: Any, objects: Any, function_values: Any,
               max_expansions: int | None = None, context_blocks: Any = None,
               budgeted: bool = False, guess: Any = None,
               skip_if_grounded_as: Any = None, **more: Any) -> Any:
        start = time.thread_time()
        result = search(state, init, objects, function_values, max_expansions,
                        context_blocks, budgeted, guess, skip_if_grounded_as, **more)
        outcome = result.outcome
        kind = ("real" if objects is state.object_types
                else "full" if budgeted else "speculative")
        searches.append({
            "kind": kind, "objects": len(objects), "actions": len(result.grounding.actions),
            "axioms": len(result.grounding.axioms), "solved": result.solved,
            "plan_length": len(result.actions) if result.actions is not None else None,
            "expanded": outcome.expanded if outcome else 0,
            "evaluated": outcome.evaluated if outcome else 0,
            "guess_followed": bool(outcome and outcome.guessed),
            "cpu_s": time.thread_time() - start})
        return result

    patch(common.PlannerState, "search", logged)
    try:
        yield
    finally:
        for owner, attribute, original in reversed(saved):
            setattr(owner, attribute, original)



@contextmanager
def solve_gc_threshold() -> Iterator[None]:
    """Collect garbage as often as a solve does (generation 0 every
    :data:`SOLVE_GC_THRESHOLD0` allocations), automatically: the profile runs the planner
    in this thread, without the waiting thread that paces a solve's collections."""
    saved = gc.get_threshold()
    gc.set_threshold(SOLVE_GC_THRESHOLD0, *saved[1:])
    try:
        yield
    finally:
        gc.set_threshold(*saved)

def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--example", default="kitchen_fluent")
    parser.add_argument("--algorithm", default="adaptive")
    parser.add_argument("--seeds", default="0-9")
    parser.add_argument("--max-time", type=float, default=60.0)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--incremental-grounding", action="store_true",
                        help="solve with PlannerConfig.incremental_grounding")
    parser.add_argument("--search", default=None,
                        help="override PlannerConfig.search (e.g. lazy-greedy)")
    args = parser.parse_args(argv)
    overrides: dict[str, Any] = {}
    if args.incremental_grounding:
        overrides["incremental_grounding"] = True
    if args.search:
        overrides["search"] = args.search
    use_one_thread()
    # An example's name, or a problem file (e.g. bench/problems/hidden19/*.yaml).
    path = Path(args.example)
    problem = load_problem(path if path.suffix == ".yaml"
                           else REPO / "problems" / "examples" / f"{args.example}.yaml")
    rows: list[dict[str, Any]] = []
    totals: Counter = Counter()
    for seed in parse_seeds(args.seeds):
        config = config_for(problem, args.algorithm, seed, args.max_time, None,
                            overrides or None)
        phases: Counter = Counter()
        searches: list[dict[str, Any]] = []
        start = time.thread_time()
        with wrapped(phases, searches), solve_gc_threshold():
            result = _solve(problem, config, time.perf_counter(), CallTracker(), [])
        cpu = time.thread_time() - start
        phases["search engine, without heuristic"] = (
            phases["search engine (incl. heuristic)"] - phases["heuristic evaluations"])
        totals.update(phases)
        totals["solve"] += cpu
        rows.append({"seed": seed, "status": result.status, "cpu_s": cpu,
                     "plan_length": len(result.plan) if result.plan is not None else None,
                     "iterations": result.stats.get("iterations"),
                     "searches": searches, "phases_s": dict(phases),
                     "stream_calls": {k: v["calls"] for k, v in
                                      result.stats.get("streams", {}).items()}})
        print(f"seed {seed}: {result.status}, {cpu:.3f} s CPU, {len(searches)} searches, "
              f"{result.stats.get('iterations')} iterations")
        print("  #  kind         objects actions solved len  expanded evaluated guess  CPU s")
        for number, s in enumerate(searches, 1):
            print(f"  {number:<2} {s['kind']:<12} {s['objects']:>7} {s['actions']:>7} "
                  f"{s['solved']!s:<6} {s['plan_length'] or '-':>4} {s['expanded']:>9} "
                  f"{s['evaluated']:>9} {'yes' if s['guess_followed'] else 'no':<5} "
                  f"{s['cpu_s']:.3f}")
    solve_total = totals["solve"]
    print(f"\nphase totals over {len(rows)} seeds (thread CPU s; phases may nest):")
    for name, seconds in sorted(totals.items(), key=lambda item: -item[1]):
        print(f"  {name:<36} {seconds:7.3f}  {100 * seconds / solve_total:5.1f} %")
    cpus = [row["cpu_s"] for row in rows]
    kinds = Counter(s["kind"] for row in rows for s in row["searches"])
    print(f"median solve CPU {statistics.median(cpus):.3f} s; searches per seed "
          f"{[len(row['searches']) for row in rows]}; by kind {dict(kinds)}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "benchmark": "planner_profile", "example": args.example,
        "algorithm": args.algorithm, "median_cpu_s": statistics.median(cpus),
        "phase_totals_s": dict(totals), "runs": rows}, indent=1))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
