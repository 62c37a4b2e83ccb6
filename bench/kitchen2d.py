"""Kitchen2D trial wall time per skill (target: pour median <= 0.5 s on one core).

Runs ``--trials`` random *valid* trials per skill (contexts from the paper's ranges,
controls uniform in the box, redrawn until valid) on the Box2D backend, single-threaded,
and prints a table of wall/CPU time and simulated time; writes JSON to ``--out``.

    OMP_NUM_THREADS=1 .venv/bin/python bench/kitchen2d.py --trials 20
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np

from ltamp_cli.backends import SkillBackend, load_backend
from ltamp_cli.trials.collect import trial_input

POUR_TARGET_S = 0.5


def bench_skill(backend: SkillBackend, skill: str, trials: int, seed: int) -> dict:
    wall, cpu, sim, scores = [], [], [], []
    for index in range(trials):
        item = trial_input(backend, skill, seed, index, valid_only=True)
        w0, c0 = time.perf_counter(), time.process_time()
        result = backend.run_trial(skill, item.context, item.control, item.seed)
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
        "success_rate": float(np.mean(np.array(scores) > 0)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--skills", default="pour,scoop,push")
    parser.add_argument("--pour-particles", type=int, default=None)
    parser.add_argument("--out", type=Path, default=Path("bench/results/kitchen2d.json"))
    args = parser.parse_args()
    options = {} if args.pour_particles is None else {"pour_particles": args.pour_particles}
    backend = load_backend("box2d", **options)
    rows = [bench_skill(backend, s, args.trials, args.seed) for s in args.skills.split(",")]
    print(f"{'skill':<7}{'trials':>7}{'wall med':>10}{'wall p90':>10}{'cpu med':>9}"
          f"{'sim med':>9}{'success':>9}")  # fmt: skip
    for row in rows:
        print(
            f"{row['skill']:<7}{row['trials']:>7}{row['wall_median_s']:>10.3f}"
            f"{row['wall_p90_s']:>10.3f}{row['cpu_median_s']:>9.3f}{row['sim_median_s']:>9.2f}"
            f"{row['success_rate']:>9.2f}"
        )
    pour = next((r for r in rows if r["skill"] == "pour"), None)
    if pour is not None:
        # CPU time is the one-core figure; wall time also counts waiting on a shared machine.
        verdict = "meets" if pour["cpu_median_s"] <= POUR_TARGET_S else "MISSES"
        print(
            f"pour: one-core (CPU) median {pour['cpu_median_s']:.3f} s {verdict} the "
            f"{POUR_TARGET_S} s target (wall median {pour['wall_median_s']:.3f} s)"
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    payload = {
        "benchmark": "kitchen2d",
        "python": platform.python_version(),
        "pour_particles": backend.config.pour.n_particles,
        "pour_target_s": POUR_TARGET_S,
        "rows": rows,
    }
    args.out.write_text(json.dumps(payload, indent=2) + "\n")


if __name__ == "__main__":
    main()
