"""PyBullet vs SAPIEN on the same Kitchen3D trials: wall time and success agreement.

Draws ``--trials`` inputs of ``--skill`` (default ``pour``; also ``scoop``, ``push``,
``stir``): contexts from the skill's context distribution, controls uniform in the box,
redrawn until the geometric pre-check passes; runs every one on both 3D backends with the
same seed, single-threaded, each backend reusing its world. Also times bare particle
stepping (``--beads`` spheres settling in a bowl) in both engines, to compare the stepping
advantage with the whole-trial one, and (``--plans N``) solves ``--problem`` (default
``problems/kitchen3d/pour_blocked.yaml``) with seeds ``0..N-1`` and executes every plan on
both backends (execution wall time, whether the goal holds physically). Prints tables;
writes JSON to ``--out`` (default ``bench/results/backends.json``).

Execution check of shipped problems (issue #20): ``--trials 0`` skips the trials and the
stepping test; ``--exec-backends`` picks the executing engines; ``--cache`` (JSONL, one row
per seed: planning CPU, per engine the execution's CPU seconds, verdicts, the failed step,
every goal fact with its bead counts) makes a run resumable; ``--first-seed`` splits the
seeds over processes; ``--max-time`` replaces the problem's wall-clock planning limit (on a
loaded machine it is a far smaller CPU limit); ``--summarise-cache`` only tabulates the
cached seeds (plans found, goals holding with Wilson 95 % intervals, median CPU per
execution). E.g.

    nice -n 5 .venv/bin/python bench/backends.py --trials 0 --plans 10 --max-time 600 \
        --problem problems/kitchen3d/coffee.yaml --exec-backends pybullet \
        --cache docs/results/exec3d/coffee_pybullet.jsonl \
        --out docs/results/exec3d/coffee_pybullet.json

    OMP_NUM_THREADS=1 .venv/bin/python bench/backends.py --trials 20 --plans 3
    OMP_NUM_THREADS=1 .venv/bin/python bench/backends.py --skill push --trials 50 \
        --out /tmp/push.json
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
from ltamp_cli.learning.metrics import wilson_interval

BACKENDS = ("pybullet", "sapien")
RESULTS_DIR = Path(__file__).resolve().parent / "results"
POUR_BLOCKED = Path(__file__).resolve().parents[1] / "problems" / "kitchen3d" / "pour_blocked.yaml"
#: Trials whose PyBullet score is at least this far from 0 are clear-cut (g = ±0.5 means
#: 95 % or 45 % of the beads in the bowl); the others are borderline.
CLEAR_SCORE = 0.5
#: The measurement compared between the engines, per skill (a key of the trial's ``info``).
MEASURES = {"pour": "fraction_in_bowl", "scoop": "fraction_of_capacity", "push": "error_m",
            "stir": "mean_displacement_m"}


def skill_inputs(backend: SkillBackend, skill: str, n: int, seed: int
                 ) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n`` (context, valid control) pairs of ``skill`` drawn with a seeded generator."""
    rng = np.random.default_rng(seed)
    spec = backend.skills()[skill]
    inputs = []
    while len(inputs) < n:
        context = backend.sample_context(skill, rng)
        controls = spec.control.sample_uniform(rng, 16)
        valid = np.flatnonzero(backend.is_valid(skill, context, controls))
        if valid.size:
            inputs.append((context, controls[int(valid[0])]))
    return inputs


def time_trials(
    name: str, inputs: list[tuple[np.ndarray, np.ndarray]], seed: int, skill: str = "pour"
) -> list[dict]:
    """Run every input on backend ``name``: wall/CPU seconds, score, measurement, steps."""
    backend = load_backend(name)
    rows = []
    try:
        for index, (context, control) in enumerate(tqdm(inputs, desc=name, leave=False)):
            w0, c0 = time.perf_counter(), time.process_time()
            result = backend.run_trial(skill, context, control, seed * 1000 + index)
            rows.append(
                {
                    "wall_s": time.perf_counter() - w0,
                    "cpu_s": time.process_time() - c0,
                    "score": result.score,
                    "valid": result.valid,
                    "measure": result.info.get(MEASURES[skill]),
                    "sim_steps": result.info.get("sim_steps", 0),
                }
            )
    finally:
        backend.close()
    return rows


def stepping_rate(name: str, beads: int, steps: int) -> float:
    """Steps per second of ``beads`` spheres falling into and settling in a nominal bowl."""
    from ltamp_cli.backends.kitchenware_geometry import vessel_geometry
    from ltamp_cli.backends.pybullet.particles import BeadSpec, grid_in_vessel
    from ltamp_cli.backends.pybullet.skills.pour import NOMINAL_BOWL

    spec = BeadSpec(count=beads)
    bowl = vessel_geometry(NOMINAL_BOWL, "bowl")
    local = grid_in_vessel(NOMINAL_BOWL, spec, np.random.default_rng(0), 6 * NOMINAL_BOWL.height)
    if name == "pybullet":
        from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial, create_kitchenware
        from ltamp_cli.backends.pybullet.particles import spawn_beads
        from ltamp_cli.backends.pybullet.world import PhysicsWorld

        world = PhysicsWorld()
        create_kitchenware(world.client, bowl, material=BodyMaterial(mass=0.0), visual=False)
        spawn_beads(world.client, spec, local)
    else:
        from ltamp_cli.backends.sapien.bodies import create_kitchenware, spawn_beads
        from ltamp_cli.backends.sapien.world import SapienWorld

        world = SapienWorld()  # type: ignore[assignment]
        create_kitchenware(world, bowl)  # type: ignore[arg-type]
        spawn_beads(world, spec, local)  # type: ignore[arg-type]
    start = time.perf_counter()
    world.step(steps)
    rate = steps / (time.perf_counter() - start)
    world.close()
    return rate


def _execution_row(report: object, cpu_s: float, wall_s: float) -> dict:
    """What one execution's report says: the times, verdicts, the step that failed (if any)
    and why, every goal fact with its measurements, the bead counts each pour, scoop,
    dump and stir left behind, and where each push left its object (and its finger gap)."""
    details = report.details  # type: ignore[attr-defined]
    goal = details.get("goal") or []
    failed = [step for step in details.get("steps", []) if not step["ok"]]
    beads = [{k: v for k, v in entry.items() if k in (
        "action", "counts", "spoonful", "left_in_spoon", "stirred", "counts_after",
        "start_xy", "rest_xy", "error_m", "finger_gap_m")}
        for entry in details.get("log", [])
        if entry.get("action") in ("pour", "scoop", "dump", "stir", "push")]
    return {
        "wall_s": wall_s,
        "cpu_s": cpu_s,
        "executed": report.success,  # type: ignore[attr-defined]
        "goal_holds": report.goal_holds,  # type: ignore[attr-defined]
        "fraction": goal[0].get("fraction") if goal else None,
        "sim_time_s": details.get("sim_time_s"),
        "failed_step": failed[0] if failed else None,
        "goal": goal,
        "skill_actions": beads,
        "initial_counts": details.get("initial_counts"),
    }


def cached_rows(cache: Path | None, path: Path, backends: tuple[str, ...]) -> dict[int, dict]:
    """The seeds of problem ``path`` in the JSONL ``cache`` (seed -> row) that are done: not
    solved, or executed on every one of ``backends``."""
    done: dict[int, dict] = {}
    if cache is not None and cache.exists():
        for line in cache.read_text().splitlines():
            row = json.loads(line)
            if row.get("problem") == path.stem and (
                    row["status"] != "solved" or all(b in row for b in backends)):
                done[int(row["seed"])] = row
    return done


def execute_plans(n: int, path: Path = POUR_BLOCKED, backends: tuple[str, ...] = BACKENDS,
                  cache: Path | None = None, max_time: float | None = None,
                  first_seed: int = 0) -> list[dict]:
    """Solve the problem at ``path`` with seeds ``first_seed .. first_seed + n - 1``;
    execute each plan on every one of ``backends``. With ``cache`` (JSONL, one row per
    seed) seeds already there with every backend are reused and each finished seed is
    appended, so a stopped run resumes.
    ``max_time`` (s, wall clock) replaces the problem's planning time limit (a loaded
    machine makes a wall-clock limit a CPU limit several times smaller)."""
    from ltamp_cli.backends.execution import execute_plan
    from ltamp_cli.planner.algorithms.common import PlannerConfig
    from ltamp_cli.planner.api import solve
    from ltamp_cli.planner.problem import load_problem

    done = cached_rows(cache, path, backends)
    problem = load_problem(path)
    rows = []
    for seed in tqdm(range(first_seed, first_seed + n), desc=path.stem, leave=False):
        if seed in done:
            rows.append(done[seed])
            continue
        w0, c0 = time.perf_counter(), time.process_time()
        options = {**problem.planner_options, "seed": seed}
        if max_time is not None:
            options["max_time"] = max_time
        result = solve(problem, PlannerConfig(**options))
        row: dict = {"problem": path.stem, "seed": seed, "status": result.status,
                     "max_time_s": options.get("max_time"),
                     "plan_cpu_s": time.process_time() - c0,
                     "plan_wall_s": time.perf_counter() - w0,
                     "actions": [step.name for step in (result.plan or ())]}
        if result.solved:
            for name in backends:
                w0, c0 = time.perf_counter(), time.process_time()
                report = execute_plan(name, problem, result, seed)
                row[name] = _execution_row(report, time.process_time() - c0,
                                           time.perf_counter() - w0)
        rows.append(row)
        if cache is not None:
            cache.parent.mkdir(parents=True, exist_ok=True)
            with cache.open("a") as handle:
                handle.write(json.dumps(row) + "\n")
    return rows


def plan_summary(plans: list[dict], backends: tuple[str, ...]) -> dict:
    """Plans found and, per backend, executions whose goal holds (Wilson 95 % intervals
    over the seeds tried) and the median CPU seconds per execution."""
    solved = [row for row in plans if row["status"] == "solved"]
    out: dict = {"seeds": len(plans), "solved": len(solved),
                 "solved_wilson95": list(wilson_interval(len(solved), len(plans))),
                 "plan_cpu_median_s": float(np.median([r["plan_cpu_s"] for r in plans]))
                 if plans and "plan_cpu_s" in plans[0] else None}
    for name in backends:
        runs = [row[name] for row in solved if name in row]
        held = sum(bool(r["goal_holds"]) for r in runs)
        out[name] = {
            "executed": len(runs),
            "goal_holds": held,
            "goal_holds_of_seeds_wilson95": list(wilson_interval(held, len(plans))),
            "goal_holds_of_plans_wilson95": list(wilson_interval(held, len(runs))),
            "cpu_median_s": float(np.median([r["cpu_s"] for r in runs]))
            if runs and "cpu_s" in runs[0] else None,
            "failures": [{"seed": row["seed"], "failed_step": row[name].get("failed_step"),
                          "goal": row[name].get("goal")}
                         for row in solved if name in row and not row[name]["goal_holds"]],
        }
    return out


def summarise(rows: dict[str, list[dict]]) -> dict:
    pyb, sap = rows["pybullet"], rows["sapien"]
    agree = [(a["score"] > 0) == (b["score"] > 0) for a, b in zip(pyb, sap, strict=True)]
    clear = [i for i, a in enumerate(pyb) if abs(a["score"]) >= CLEAR_SCORE]
    measure_gaps = [
        abs(a["measure"] - b["measure"])
        for a, b in zip(pyb, sap, strict=True)
        if a["measure"] is not None and b["measure"] is not None
    ]
    per_backend = {}
    for name, trial_rows in rows.items():
        wall = np.array([r["wall_s"] for r in trial_rows])
        steps = np.array([r["sim_steps"] for r in trial_rows])
        per_backend[name] = {
            "wall_median_s": float(np.median(wall)),
            "wall_total_s": float(wall.sum()),
            "cpu_median_s": float(np.median([r["cpu_s"] for r in trial_rows])),
            "success_rate": float(np.mean([r["score"] > 0 for r in trial_rows])),
            "trial_steps_per_s": float(steps.sum() / wall.sum()),
        }
    return {
        "per_backend": per_backend,
        "speedup_median": per_backend["pybullet"]["wall_median_s"]
        / per_backend["sapien"]["wall_median_s"],
        "speedup_total": per_backend["pybullet"]["wall_total_s"]
        / per_backend["sapien"]["wall_total_s"],
        # CPU time is the fairer ratio when other processes share the cores.
        "speedup_cpu_median": per_backend["pybullet"]["cpu_median_s"]
        / per_backend["sapien"]["cpu_median_s"],
        "agreement": float(np.mean(agree)),
        "clear_cut_trials": len(clear),
        "agreement_clear_cut": float(np.mean([agree[i] for i in clear])) if clear else None,
        "disagreements": [i for i, same in enumerate(agree) if not same],
        "measure_mean_abs_diff": float(np.mean(measure_gaps)) if measure_gaps else None,
    }


def print_trials(args: argparse.Namespace, summary: dict, stepping: dict) -> None:
    """The whole-trial and stepping tables."""
    print(f"{'backend':<10}{'n':>4}{'wall med':>10}{'wall sum':>10}{'cpu med':>9}"
          f"{'steps/s':>9}{'success':>9}")
    for name in BACKENDS:
        row = summary["per_backend"][name]
        print(f"{name:<10}{args.trials:>4}{row['wall_median_s']:>10.2f}"
              f"{row['wall_total_s']:>10.1f}{row['cpu_median_s']:>9.2f}"
              f"{row['trial_steps_per_s']:>9.0f}{row['success_rate']:>9.2f}")
    print(f"whole {args.skill} trials: SAPIEN {summary['speedup_median']:.1f}x faster (median), "
          f"{summary['speedup_total']:.1f}x (total), "
          f"{summary['speedup_cpu_median']:.1f}x (median CPU)")
    step_speedup = stepping["sapien"] / stepping["pybullet"]
    print(f"bare stepping, {args.beads} beads: PyBullet {stepping['pybullet']:.0f} steps/s, "
          f"SAPIEN {stepping['sapien']:.0f} steps/s ({step_speedup:.1f}x)")
    clear = summary["agreement_clear_cut"]
    clear_text = "n/a" if clear is None else f"{clear:.0%}"
    print(f"success labels agree on {summary['agreement']:.0%} of trials, {clear_text} of the "
          f"{summary['clear_cut_trials']} clear-cut ones (PyBullet |score| >= {CLEAR_SCORE}); "
          f"disagreeing trials: {summary['disagreements']}; mean |{MEASURES[args.skill]} "
          f"difference| {summary['measure_mean_abs_diff']:.3f}")


def print_plans(problem: str, plans: list[dict], summary: dict,
                backends: tuple[str, ...]) -> None:
    """One line per seed (plan status, per backend: CPU s and whether the goal holds), then
    the totals with Wilson intervals."""
    if not plans:
        return
    header = f"{'seed':>4}{'status':>10}{'plan cpu':>9}"
    for name in backends:
        header += f"{name[:3] + ' cpu':>9}{name[:3] + ' goal':>9}"
    print(header)
    for row in plans:
        line = f"{row['seed']:>4}{row['status']:>10}{row.get('plan_cpu_s', float('nan')):>9.1f}"
        for name in backends:
            run = row.get(name)
            line += ("" if run is None else
                     f"{run.get('cpu_s', float('nan')):>9.1f}{run['goal_holds']!s:>9}")
        print(line)
    print(f"{problem}: {summary['solved']}/{summary['seeds']} seeds planned "
          f"(Wilson {summary['solved_wilson95'][0]:.2f}-{summary['solved_wilson95'][1]:.2f})")
    for name in backends:
        b = summary[name]
        low, high = b["goal_holds_of_seeds_wilson95"]
        cpu = b["cpu_median_s"]
        print(f"  {name}: goal holds in {b['goal_holds']}/{summary['seeds']} seeds "
              f"(Wilson {low:.2f}-{high:.2f}), median CPU per execution "
              f"{'n/a' if cpu is None else f'{cpu:.1f} s'}")
    if len(backends) == 2 and all(len(backends) == sum(n in r for n in backends)
                                  for r in plans if r["status"] == "solved"):
        executed = [r for r in plans if r["status"] == "solved"]
        same = sum(r[backends[0]]["goal_holds"] == r[backends[1]]["goal_holds"]
                   for r in executed)
        print(f"  goal verdicts agree on {same}/{len(executed)} plans")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--beads", type=int, default=200, help="spheres for the stepping test")
    parser.add_argument("--steps", type=int, default=480, help="steps for the stepping test")
    parser.add_argument("--skill", choices=sorted(MEASURES), default="pour")
    parser.add_argument("--plans", type=int, default=0, help="plans to execute")
    parser.add_argument("--problem", type=Path, default=POUR_BLOCKED,
                        help="problem whose plans --plans executes")
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "backends.json")
    parser.add_argument("--exec-backends", nargs="+", choices=BACKENDS, default=list(BACKENDS),
                        help="backends that execute the --plans plans")
    parser.add_argument("--cache", type=Path, default=None,
                        help="JSONL of executed seeds: reused, and appended to (resumable)")
    parser.add_argument("--first-seed", type=int, default=0,
                        help="the plans' seeds are first-seed .. first-seed + plans - 1")
    parser.add_argument("--summarise-cache", action="store_true",
                        help="no planning: tabulate every seed of --problem in --cache")
    parser.add_argument("--max-time", type=float, default=None,
                        help="planning wall-clock limit (s) instead of the problem's")
    args = parser.parse_args()
    if args.max_time is not None and args.max_time <= 0:
        parser.error("--max-time must be positive")
    if args.trials < 0 or args.plans < 0 or args.first_seed < 0:
        parser.error("--trials, --plans and --first-seed must be >= 0")
    if not args.problem.is_file():
        parser.error(f"no problem file {args.problem}")
    exec_backends = tuple(args.exec_backends)
    summary: dict | None = None
    stepping: dict | None = None
    step_speedup = None
    inputs: list[tuple[np.ndarray, np.ndarray]] = []
    rows: dict[str, list[dict]] = {name: [] for name in BACKENDS}
    if args.trials:  # --trials 0: only the plans
        # Same generator draws for both backends: contexts and pre-checks are engine-independent.
        probe = load_backend("pybullet")
        inputs = skill_inputs(probe, args.skill, args.trials, args.seed)
        probe.close()
        rows = {name: time_trials(name, inputs, args.seed, args.skill) for name in BACKENDS}
        summary = summarise(rows)
        stepping = {name: stepping_rate(name, args.beads, args.steps) for name in BACKENDS}
        step_speedup = stepping["sapien"] / stepping["pybullet"]
        print_trials(args, summary, stepping)
    if args.summarise_cache:
        if args.cache is None:
            parser.error("--summarise-cache needs --cache")
        done = cached_rows(args.cache, args.problem, exec_backends)
        plans = [done[seed] for seed in sorted(done)]
    else:
        plans = execute_plans(args.plans, args.problem, exec_backends, args.cache,
                              args.max_time, args.first_seed)
    plans_summary = plan_summary(plans, exec_backends)
    print_plans(args.problem.stem, plans, plans_summary, exec_backends)
    payload = {
        "benchmark": "backends",
        "python": platform.python_version(),
        "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
        "skill": args.skill,
        "measure": MEASURES[args.skill],
        "trials": args.trials,
        "seed": args.seed,
        "clear_score": CLEAR_SCORE,
        "summary": summary,
        "stepping": {"beads": args.beads, "steps": args.steps, "steps_per_s": stepping,
                     "speedup": step_speedup},
        "problem": str(args.problem),
        "exec_backends": list(exec_backends),
        "max_time_s": args.max_time,
        "first_seed": args.first_seed,
        "plans_summary": plans_summary,
        "plans": plans,
        "rows": [
            {"context": c.tolist(), "control": u.tolist(),
             **{name: rows[name][i] for name in BACKENDS}}
            for i, (c, u) in enumerate(inputs)
        ],
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(payload, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
