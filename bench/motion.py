"""Benchmark the Panda's IK, RRT-Connect and collision checks in the Kitchen3D scene.

Prints a table and writes JSON (``--out``, default ``bench/results/motion.json``).
Run with ``OMP_NUM_THREADS=1``: ``python bench/motion.py [--quick]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np
import pybullet
from tqdm import tqdm

from ltamp_cli.backends.pybullet.robot import (
    ArmCollisionChecker,
    IKConfig,
    Pose,
    add_box,
    build_kitchen_scene,
    plan_arm_motion,
    solve_ik,
)
from ltamp_cli.motion import RRTConnectConfig, is_path_valid

DEFAULT_OUT = Path(__file__).resolve().parent / "results" / "motion.json"


def bench_ik(n_targets: int, seed: int) -> dict[str, float]:
    """IK on targets that are FK images of uniform random configurations (reachable)."""
    client = pybullet.connect(pybullet.DIRECT)
    try:
        arm = build_kitchen_scene(client, n_arms=1).arms[0]
        rng = np.random.default_rng(seed)
        targets = [arm.forward_kinematics(arm.sample_configuration(rng)) for _ in range(n_targets)]
        times, solved = [], 0
        for target in tqdm(targets, desc="ik", file=sys.stderr):
            began = time.perf_counter()
            q = solve_ik(arm, target, rng, IKConfig())
            times.append(time.perf_counter() - began)
            solved += q is not None
        return {
            "ik_targets": n_targets,
            "ik_success_rate": solved / n_targets,
            "ik_median_ms": 1e3 * float(np.median(times)),
            "ik_mean_ms": 1e3 * float(np.mean(times)),
        }
    finally:
        pybullet.disconnect(physicsClientId=client)


def bench_rrt(n_plans: int, seed: int) -> dict[str, float]:
    """RRT-Connect around a wall on the table, top-down grasp poses on either side."""
    client = pybullet.connect(pybullet.DIRECT)
    try:
        scene = build_kitchen_scene(client, n_arms=1)
        arm = scene.arms[0]
        wall = add_box(
            client, (0.03, 0.2, 0.12), Pose(scene.table_centre + np.array([-0.05, 0, 0.12]))
        )
        checker = ArmCollisionChecker(arm, scene.obstacles_for(0, [wall]))
        rng = np.random.default_rng(seed)
        queries = []
        while len(queries) < n_plans:
            a = Pose.from_euler(
                scene.table_centre
                + np.array([rng.uniform(-0.25, -0.15), rng.uniform(-0.2, 0.2), 0.1]),
                roll=np.pi,
            )
            b = Pose.from_euler(
                scene.table_centre
                + np.array([rng.uniform(0.05, 0.15), rng.uniform(-0.2, 0.2), 0.1]),
                roll=np.pi,
            )
            q_a = solve_ik(arm, a, rng, is_valid=checker)
            q_b = solve_ik(arm, b, rng, is_valid=checker)
            if q_a is not None and q_b is not None:
                queries.append((q_a, q_b))
        times, checks, solved, dense_ok = [], [], 0, 0
        for index, (q_a, q_b) in enumerate(tqdm(queries, desc="rrt-connect", file=sys.stderr)):
            plan = plan_arm_motion(
                arm, q_a, q_b, checker, RRTConnectConfig(seed=index, time_limit=5.0)
            )
            times.append(plan.planning_time)
            checks.append(plan.n_validity_checks)
            if plan.path is not None:
                solved += 1
                dense_ok += is_path_valid(plan.path, checker, 0.005)
        return {
            "rrt_queries": n_plans,
            "rrt_success_rate": solved / n_plans,
            "rrt_dense_recheck_pass_rate": dense_ok / max(1, solved),
            "rrt_median_ms": 1e3 * float(np.median(times)),
            "rrt_p90_ms": 1e3 * float(np.percentile(times, 90)),
            "rrt_median_validity_checks": float(np.median(checks)),
        }
    finally:
        pybullet.disconnect(physicsClientId=client)


def bench_collision(n_checks: int, seed: int) -> dict[str, float]:
    """Checks per second on uniform random configurations (table, floor, pedestal, wall)."""
    client = pybullet.connect(pybullet.DIRECT)
    try:
        scene = build_kitchen_scene(client, n_arms=2)
        arm = scene.arms[0]
        wall = add_box(
            client, (0.03, 0.2, 0.12), Pose(scene.table_centre + np.array([-0.05, 0, 0.12]))
        )
        rng = np.random.default_rng(seed)
        samples = [arm.sample_configuration(rng) for _ in range(n_checks)]
        results = {}
        for name, self_collision in (("with_self", True), ("no_self", False)):
            checker = ArmCollisionChecker(
                arm, scene.obstacles_for(0, [wall]), self_collision=self_collision
            )
            began = time.perf_counter()
            valid = sum(checker(q) for q in samples)
            elapsed = time.perf_counter() - began
            results[f"collision_checks_per_s_{name}"] = n_checks / elapsed
            results[f"collision_valid_fraction_{name}"] = valid / n_checks
        return results
    finally:
        pybullet.disconnect(physicsClientId=client)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--quick", action="store_true", help="fewer samples (CI smoke run)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    scale = 0.2 if args.quick else 1.0
    results: dict[str, float | str] = {"python": platform.python_version()}
    results.update(bench_ik(int(100 * scale), args.seed))
    results.update(bench_rrt(max(3, int(20 * scale)), args.seed))
    results.update(bench_collision(int(5000 * scale), args.seed))
    width = max(len(key) for key in results)
    print(f"{'metric':<{width}}  value")
    for key, value in results.items():
        shown = f"{value:.3f}" if isinstance(value, float) else str(value)
        print(f"{key:<{width}}  {shown}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
