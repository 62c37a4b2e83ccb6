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


def execute_plans(n: int, path: Path = POUR_BLOCKED) -> list[dict]:
    """Solve the problem at ``path`` with seeds ``0..n-1``; execute each plan on both
    backends."""
    from ltamp_cli.backends.execution import execute_plan
    from ltamp_cli.planner.algorithms.common import PlannerConfig
    from ltamp_cli.planner.api import solve
    from ltamp_cli.planner.problem import load_problem

    problem = load_problem(path)
    rows = []
    for seed in tqdm(range(n), desc=path.stem, leave=False):
        result = solve(problem, PlannerConfig(**{**problem.planner_options, "seed": seed}))
        row: dict = {"seed": seed, "status": result.status}
        if result.solved:
            for name in BACKENDS:
                start = time.perf_counter()
                report = execute_plan(name, problem, result, seed)
                goal = report.details["goal"][0] if report.details.get("goal") else {}
                row[name] = {
                    "wall_s": time.perf_counter() - start,
                    "executed": report.success,
                    "goal_holds": report.goal_holds,
                    "fraction": goal.get("fraction"),
                    "sim_time_s": report.details.get("sim_time_s"),
                }
        rows.append(row)
    return rows


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
    args = parser.parse_args()
    # Same generator draws for both backends: contexts and pre-checks are engine-independent.
    probe = load_backend("pybullet")
    inputs = skill_inputs(probe, args.skill, args.trials, args.seed)
    probe.close()
    rows = {name: time_trials(name, inputs, args.seed, args.skill) for name in BACKENDS}
    summary = summarise(rows)
    stepping = {name: stepping_rate(name, args.beads, args.steps) for name in BACKENDS}
    plans = execute_plans(args.plans, args.problem)

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
    executed = [row for row in plans if "sapien" in row]
    if executed:
        print(f"{'seed':>4}{'pyb exec s':>11}{'pyb goal':>9}{'sap exec s':>11}{'sap goal':>9}")
        for row in executed:
            pyb, sap = row["pybullet"], row["sapien"]
            print(f"{row['seed']:>4}{pyb['wall_s']:>11.1f}{pyb['goal_holds']!s:>9}"
                  f"{sap['wall_s']:>11.1f}{sap['goal_holds']!s:>9}")
        same = sum(r["pybullet"]["goal_holds"] == r["sapien"]["goal_holds"] for r in executed)
        ratio = sum(r["pybullet"]["wall_s"] for r in executed) / sum(
            r["sapien"]["wall_s"] for r in executed)
        print(f"{args.problem.stem} executions: goal verdicts agree on {same}/{len(executed)} "
              f"plans; SAPIEN executes {ratio:.1f}x faster")
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
