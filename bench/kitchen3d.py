"""Kitchen3D (PyBullet) trial wall time per skill (target: pour median <= 3 s on one core)
and planning time per problem (target: pour_blocked median <= 20 s).

Runs ``--trials`` random *valid* trials per skill (contexts from the randomised kitchenware
distribution, controls uniform in the box, redrawn until the geometric pre-check passes),
single-threaded, one reused physics client. Prints a table of wall/CPU time, simulated time
and the pre-check cost per control; writes JSON to ``--out``.

    OMP_NUM_THREADS=1 .venv/bin/python bench/kitchen3d.py --trials 10
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ltamp_cli.backends import SkillBackend, load_backend

POUR_TARGET_S = 3.0
POUR_BLOCKED_TARGET_S = 20.0
PROBLEMS_DIR = Path(__file__).resolve().parents[1] / "problems" / "kitchen3d"


def bench_planning(problem_name: str, seeds: list[int], max_time: float = 120.0) -> dict:
    """Plan ``problems/kitchen3d/<problem_name>.yaml`` once per seed (the problem's planner
    options, at most ``max_time`` wall seconds): wall and CPU seconds (CPU: this process, so
    the planner's single-core cost even on a loaded machine), status and plan length per
    run, and their medians."""
    from ltamp_cli.planner.algorithms.common import PlannerConfig
    from ltamp_cli.planner.api import solve
    from ltamp_cli.planner.problem import load_problem

    problem = load_problem(PROBLEMS_DIR / f"{problem_name}.yaml")
    runs = []
    for seed in tqdm(seeds, desc=f"plan {problem_name}", leave=False):
        options = {**problem.planner_options, "seed": seed, "max_time": max_time}
        start, cpu = time.perf_counter(), time.process_time()
        result = solve(problem, PlannerConfig(**options))
        runs.append({"seed": seed, "status": result.status,
                     "time_s": time.perf_counter() - start,
                     "cpu_s": time.process_time() - cpu,
                     "actions": len(result.plan or ())})
    times = [run["time_s"] for run in runs]
    return {"problem": problem_name, "runs": runs, "time_median_s": float(np.median(times)),
            "cpu_median_s": float(np.median([run["cpu_s"] for run in runs])),
            "solved": sum(run["status"] == "solved" for run in runs)}


def valid_input(
    backend: SkillBackend, skill: str, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, float, int]:
    """A context, the first valid uniform control, pre-check seconds per control, #checked."""
    spec = backend.skills()[skill]
    checked, check_s = 0, 0.0
    while True:
        context = backend.sample_context(skill, rng)
        controls = spec.control.sample_uniform(rng, 16)
        start = time.perf_counter()
        valid = backend.is_valid(skill, context, controls)
        check_s += time.perf_counter() - start
        checked += len(controls)
        if valid.any():
            return context, controls[int(np.flatnonzero(valid)[0])], check_s / checked, checked


def bench_skill(backend: SkillBackend, skill: str, trials: int, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    wall, cpu, sim, scores, check, checked = [], [], [], [], [], 0
    for index in tqdm(range(trials), desc=skill, leave=False):
        context, control, per_control, n = valid_input(backend, skill, rng)
        check.append(per_control)
        checked += n
        w0, c0 = time.perf_counter(), time.process_time()
        result = backend.run_trial(skill, context, control, seed * 1000 + index)
        wall.append(time.perf_counter() - w0)
        cpu.append(time.process_time() - c0)
        sim.append(float(result.info.get("sim_time_s", 0.0)))
        scores.append(result.score)
    return {
        "skill": skill,
        "trials": trials,
        "wall_median_s": float(np.median(wall)),
        "wall_p90_s": float(np.percentile(wall, 90)),
        "cpu_median_s": float(np.median(cpu)),
        "sim_median_s": float(np.median(sim)),
        "precheck_ms_per_control": 1000.0 * float(np.mean(check)),
        "controls_checked": checked,
        "success_rate": float(np.mean(np.asarray(scores) > 0)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--skills", nargs="*", default=["pour", "scoop"],
                        help="skills to time (none: skip the trials)")
    parser.add_argument("--out", type=Path, default=Path("bench/results/kitchen3d.json"))
    parser.add_argument("--problems", nargs="*",
                        default=["pour_blocked", "wash", "unclog", "push_to_reach", "coffee"],
                        help="problems/kitchen3d/*.yaml to plan (none: skip planning)")
    parser.add_argument("--plan-runs", type=int, default=3, help="planner seeds per problem")
    parser.add_argument("--plan-max-time", type=float, default=120.0,
                        help="wall seconds per planning run")
    args = parser.parse_args()
    backend = load_backend("pybullet")
    try:
        rows = [bench_skill(backend, skill, args.trials, args.seed) for skill in args.skills]
    finally:
        backend.close()
    header = f"{'skill':<7}{'n':>4}{'wall med':>10}{'wall p90':>10}{'cpu med':>9}"
    header += f"{'sim med':>9}{'check ms':>10}{'success':>9}"
    print(header)
    for row in rows:
        print(
            f"{row['skill']:<7}{row['trials']:>4}{row['wall_median_s']:>10.2f}"
            f"{row['wall_p90_s']:>10.2f}{row['cpu_median_s']:>9.2f}{row['sim_median_s']:>9.2f}"
            f"{row['precheck_ms_per_control']:>10.1f}{row['success_rate']:>9.2f}"
        )
    pour = next((row for row in rows if row["skill"] == "pour"), None)
    if pour is not None:
        verdict = "meets" if pour["wall_median_s"] <= POUR_TARGET_S else "MISSES"
        print(f"pour median {pour['wall_median_s']:.2f} s {verdict} the {POUR_TARGET_S} s target")
    planning = [bench_planning(name, list(range(args.plan_runs)), args.plan_max_time)
                for name in args.problems]
    if planning:
        print(f"{'problem':<14}{'runs':>5}{'solved':>7}{'plan med s':>11}{'cpu med s':>10}")
        for row in planning:
            print(f"{row['problem']:<14}{len(row['runs']):>5}{row['solved']:>7}"
                  f"{row['time_median_s']:>11.2f}{row['cpu_median_s']:>10.2f}")
    blocked = next((row for row in planning if row["problem"] == "pour_blocked"), None)
    if blocked is not None:
        verdict = "meets" if blocked["time_median_s"] <= POUR_BLOCKED_TARGET_S else "MISSES"
        print(f"pour_blocked planning median {blocked['time_median_s']:.2f} s {verdict} the "
              f"{POUR_BLOCKED_TARGET_S} s target")
    payload = {
        "benchmark": "kitchen3d",
        "python": platform.python_version(),
        "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
        "pour_target_s": POUR_TARGET_S,
        "results": rows,
        "pour_blocked_target_s": POUR_BLOCKED_TARGET_S,
        "planning": planning,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(payload, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
