"""Experiment 7 — the integrated coffee task (the paper's section "Integrated system").

Plans ``problems/kitchen2d/coffee.yaml`` (Box2D kitchen, shipped learned pour/scoop models)
and, when it exists in this checkout, ``problems/kitchen3d/coffee.yaml`` (PyBullet) for
several planner seeds (each seed also randomises the 2D object arrangement); reports planning
wall and CPU time (the planner's wall-clock limit is stretched by the machine's load,
:func:`bench.paper.common.wall_limit`). ``--full`` also executes the 2D plans in Box2D and
checks the goal physically (:func:`bench.kitchen2d.bench_coffee`). The paper gives no
planning times for this task (it is a demonstration), so there is no number to compare with.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from tqdm import tqdm

from bench.paper.common import REPO, Context, mean_std, unavailable, wall_limit, write_json
from bench.paper.kernel_learning import plan_once

NAME = "coffee"
PROBLEMS = {"2D": "problems/kitchen2d/coffee.yaml", "3D": "problems/kitchen3d/coffee.yaml"}
SIZES: dict[str, dict[str, Any]] = {
    "smoke": {"seeds": {"2D": 1}, "max_time": 30.0, "execute_2d": False},
    "quick": {"seeds": {"2D": 3, "3D": 1}, "max_time": 120.0, "execute_2d": False},
    "full": {"seeds": {"2D": 10, "3D": 10}, "max_time": 120.0, "execute_2d": True},
}


def run(ctx: Context) -> dict[str, Any]:
    """Writes ``coffee.json`` and ``coffee.png`` (planning time per seed)."""
    import ltamp_cli.learning.model  # noqa: F401 - warm import: torch is not planning time
    from ltamp_cli.planner.problem import load_problem

    started = time.perf_counter()
    sizes = ctx.sizes(SIZES)
    rows: dict[str, Any] = {}
    for kitchen, relative in PROBLEMS.items():
        n = sizes["seeds"].get(kitchen, 0)
        path = REPO / relative
        if not path.is_file():
            rows[kitchen] = {"problem": relative, **unavailable(relative)}
            continue
        if n == 0:
            rows[kitchen] = {"problem": relative, "available": True, "skipped": True,
                             "note": f"not run in {ctx.mode} mode"}
            continue
        problem = load_problem(path)
        runs = [plan_once(problem, seed, wall_limit(sizes["max_time"]))
                for seed in tqdm(range(n), desc=f"coffee {kitchen}", disable=not ctx.progress)]
        solved = [r for r in runs if r["status"] == "solved"]
        rows[kitchen] = {
            "problem": relative, "available": True, "runs": runs,
            "solved": len(solved), "n": n,
            "plan_wall_s": mean_std([r["wall_s"] for r in solved]),
            "plan_cpu_s": mean_std([r["cpu_s"] for r in solved]),
            "plan_wall_median_s": float(np.median([r["wall_s"] for r in solved]))
            if solved else None,
            "actions": mean_std([r["actions"] for r in solved]),
        }
        if kitchen == "2D" and sizes["execute_2d"]:
            from bench.kitchen2d import bench_coffee

            execution = bench_coffee(list(range(n)), sizes["max_time"])
            rows[kitchen]["executed_successes"] = execution["executed_successes"]
            rows[kitchen]["execution"] = execution["rows"]
    _plot(rows, ctx)
    payload = {"sizes": sizes, "kitchens": rows, "pngs": [f"{NAME}.png"]}
    write_json(ctx, NAME, payload, started)
    return payload


def _plot(rows: dict[str, Any], ctx: Context) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(6, 3.4))
    for kitchen, row in rows.items():
        runs = row.get("runs", [])
        if runs:
            axis.plot([r["seed"] for r in runs], [r["wall_s"] for r in runs], "o-",
                      label=f"{kitchen} wall")
            axis.plot([r["seed"] for r in runs], [r["cpu_s"] for r in runs], "s--",
                      label=f"{kitchen} CPU")
    axis.set_xlabel("planner seed")
    axis.set_ylabel("planning time (s)")
    missing = [k for k, r in rows.items() if not r.get("available")]
    title = f"Coffee task planning ({ctx.mode})"
    if missing:
        title += f"; not in this checkout: {', '.join(missing)}"
    axis.set_title(title, fontsize=9)
    axis.legend(fontsize=8)
    axis.grid(alpha=0.3)
    figure.tight_layout()
    figure.savefig(ctx.out / f"{NAME}.png", dpi=90)
    plt.close(figure)
