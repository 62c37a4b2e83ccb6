"""Where can the Kitchen2D push succeed, and where does active learning find its successes?

Two measurements (issue #20, the push's θ* over the whole goal box), printed as tables and
written to ``--out`` (JSON):

1. **Reachability.** For each goal of a ``--grid`` × ``--grid`` lattice over the skill's
   context box, ``--controls`` uniformly random *valid* controls (seeded) run once each in
   the shipped push. Per goal: the success rate (score > 0) with its 95 % Wilson interval
   and the best score. A goal no control reaches would mean the context box is wrong; a
   tiny rate means the success set is a needle in the 4-D control box.
2. **Where training trials succeed.** For each ``--trials`` JSONL (``ltamp train`` output),
   trials and successes by goal distance from the object's start (the origin), with Wilson
   intervals: within 2 units of the origin an unpushed object already succeeds.

    OMP_NUM_THREADS=1 .venv/bin/python bench/push_reach.py --grid 5 --controls 2000 \\
        --trials models/kitchen2d/push/trials.jsonl --out docs/results/push/reach.json

A push trial costs ~1.5 ms CPU; 25 goals × 2000 controls take ~80 s CPU.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

from ltamp_cli.backends.box2d.backend import Kitchen2DBackend
from ltamp_cli.learning.metrics import wilson_interval

#: Goal-distance bands (world units from the object's start) of the training-trial table.
BANDS = ((0.0, 2.0), (2.0, 4.0), (4.0, 8.0))


def reach_rows(backend: Kitchen2DBackend, grid: int, controls: int, seed: int) -> list[dict]:
    """One row per lattice goal: random valid controls' success rate and best score."""
    spec = backend.skills()["push"]
    lows, highs = spec.context.lows, spec.context.highs
    rng = np.random.default_rng(seed)
    rows = []
    for gx in np.linspace(lows[0], highs[0], grid):
        for gy in np.linspace(lows[1], highs[1], grid):
            goal = np.array([gx, gy])
            chosen = np.empty((0, spec.control.dim))
            while len(chosen) < controls:
                batch = spec.control.sample_uniform(rng, controls)
                chosen = np.vstack([chosen, batch[backend.is_valid("push", goal, batch)]])
            scores = np.array([backend.run_trial("push", goal, u, seed=0).score
                               for u in chosen[:controls]])
            wins = int((scores > 0).sum())
            low, high = wilson_interval(wins, controls)
            rows.append({"goal": [float(gx), float(gy)], "n": controls, "successes": wins,
                         "rate": wins / controls, "wilson95": [low, high],
                         "best_score": float(scores.max())})
    return rows


def band_rows(path: Path) -> list[dict]:
    """Trials and successes of a training run by goal distance (one row per band)."""
    records = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    goals = np.array([r["context"] for r in records], dtype=float).reshape(-1, 2)
    wins = np.array([r["score"] > 0 for r in records])
    distance = np.hypot(goals[:, 0], goals[:, 1])
    rows = []
    for low, high in BANDS:
        mask = (distance >= low) & (distance < high)
        n, k = int(mask.sum()), int(wins[mask].sum())
        rows.append({"trials_file": str(path), "band": [low, high], "n": n, "successes": k,
                     "rate": k / n if n else None, "wilson95": list(wilson_interval(k, n))})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", type=int, default=5, help="lattice goals per axis")
    parser.add_argument("--controls", type=int, default=2000, help="random controls per goal")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--trials", type=Path, nargs="*", default=[],
                        help="training-trial JSONL files to tabulate by goal distance")
    parser.add_argument("--out", type=Path, required=True, help="JSON file to write")
    args = parser.parse_args()
    if args.grid < 2 or args.controls < 1:
        print(f"error: --grid must be >= 2 and --controls >= 1, got {args.grid}, "
              f"{args.controls}", file=sys.stderr)
        sys.exit(2)
    for path in args.trials:
        if not path.is_file():
            print(f"error: --trials: no file {path}", file=sys.stderr)
            sys.exit(2)
    backend = Kitchen2DBackend()
    start = time.process_time()
    reach = reach_rows(backend, args.grid, args.controls, args.seed)
    cpu = time.process_time() - start
    print(f"{'goal':>14} {'success rate':>13} {'Wilson 95 %':>17} {'best score':>11}")
    for row in reach:
        gx, gy = row["goal"]
        low, high = row["wilson95"]
        print(f"({gx:5.1f},{gy:5.1f}) {row['rate']:13.4f}   {low:.4f}-{high:.4f} "
              f"{row['best_score']:11.2f}")
    bands = [row for path in args.trials for row in band_rows(path)]
    for row in bands:
        low, high = row["wilson95"]
        print(f"{row['trials_file']}: |goal| in [{row['band'][0]}, {row['band'][1]}): "
              f"{row['successes']}/{row['n']} succeed (Wilson {low:.3f}-{high:.3f})")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "grid": args.grid, "controls_per_goal": args.controls, "seed": args.seed,
        "reach_cpu_s": cpu, "reach": reach, "training_bands": bands,
        "python": platform.python_version(),
    }, indent=1) + "\n")
    print(f"reachability CPU {cpu:.1f} s; wrote {args.out}")


if __name__ == "__main__":
    main()
