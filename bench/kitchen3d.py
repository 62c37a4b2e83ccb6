"""Kitchen3D (PyBullet) trial wall time per skill (target: pour median <= 3 s on one core).

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
    parser.add_argument("--skills", nargs="+", default=["pour", "scoop"])
    parser.add_argument("--out", type=Path, default=Path("bench/results/kitchen3d.json"))
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
    payload = {
        "benchmark": "kitchen3d",
        "python": platform.python_version(),
        "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
        "pour_target_s": POUR_TARGET_S,
        "results": rows,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(payload, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
