"""Where θ* of a scoop model failed: does θ* fail again, and is there a good control nearby?

For each context whose θ* trial failed in ``--eval`` (a ``bench/kitchen3d_models.py --log``
file: per context, θ*'s trial first, then the random baseline's), this runs on PyBullet (the
shipped models' ground truth):

* θ* again with ``--repeats`` other trial seeds (is the miss the label's noise?);
* ``--local`` pre-check-valid perturbations of θ* (Gaussian, ``--radius`` standard deviation in
  normalised control units ``[-1, 1]``, clipped to the box), one trial each (is there a good
  control near θ*, i.e. is the miss θ*'s search or the model?);
* the best of those once more with ``--verify-seeds`` seeds.

It also reports ``μ/σ`` of ``--model`` at each control and an estimate of the bead bed's depth
(the trial's mean bead count and size packed at density 0.6 into the bowl's inner frustum),
against the spoon head's depth. One JSON line per trial is appended to ``--out`` as it
finishes (a rerun skips the trials already there); ``--summary`` gets one row per context.

    OMP_NUM_THREADS=1 .venv/bin/python bench/scoop_misses.py --model MODEL \\
        --eval docs/results/scoop3d/eval_trials_186.jsonl --local 10 --repeats 2 \\
        --out docs/results/scoop3d/misses_trials.jsonl \\
        --summary docs/results/scoop3d/misses_186.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.kitchenware_geometry import SpoonDims
from ltamp_cli.backends.skills3d.scoop import BED_PACKING, ScoopContext, ScoopSettings
from ltamp_cli.backends.skills3d.scoop import bed_depth_m as skill_bed_depth_m

ROOT = Path(__file__).resolve().parents[1]
#: Mean bead radius (m) of a scoop trial (``sample_beads``: N(6, 0.5) mm truncated to 5-7).
MEAN_BEAD_RADIUS_M = 0.006
PACKING = BED_PACKING


def failed_theta_star(path: Path) -> list[tuple[int, list[float], list[float], float]]:
    """``(context index, context (4,), θ* (5,), θ*'s score)`` of each failed θ* trial."""
    first: dict[int, dict] = {}
    for line in path.open():
        record = json.loads(line)
        first.setdefault(record["seed"], record)
    return [(index, r["context"], r["control"], r["score"]) for index, r in sorted(first.items())
            if not (r["valid"] and r["score"] > 0)]


def bed_depth_m(context: np.ndarray, beads: float) -> float:
    """Estimated depth (m) of ``beads`` settled beads of the mean radius in the bowl of
    ``context`` (4,): the skill's own estimate (:func:`~ltamp_cli.backends.skills3d.scoop.
    bed_depth_m`, volume at packing :data:`PACKING` filling the inner frustum)."""
    bowl = ScoopContext.from_array(context).bowl
    return skill_bed_depth_m(bowl, beads, MEAN_BEAD_RADIUS_M)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, required=True)
    parser.add_argument("--eval", type=Path,
                        default=ROOT / "docs/results/scoop3d/eval_trials_186.jsonl")
    parser.add_argument("--local", type=int, default=10)
    parser.add_argument("--radius", type=float, default=0.2)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--verify-seeds", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--summary", type=Path, required=True)
    args = parser.parse_args(argv)
    if args.local < 1 or args.repeats < 0 or args.verify_seeds < 0 or args.radius <= 0:
        print("scoop_misses: need --local >= 1, --repeats >= 0, --verify-seeds >= 0, "
              "--radius > 0", file=sys.stderr)
        return 2
    if not args.eval.is_file():
        print(f"scoop_misses: no eval log {args.eval}", file=sys.stderr)
        return 2
    from ltamp_cli.learning.model import LevelSetModel

    model = LevelSetModel.load(str(args.model))
    done: dict[tuple, dict] = {}
    if args.out.exists():
        for record in map(json.loads, args.out.open()):
            done[(record["context_index"], record["kind"], record["k"], record["seed"])] = record
    backend = load_backend("pybullet")
    space = backend.skills()["scoop"].control
    lows, highs = np.asarray(space.lows), np.asarray(space.highs)
    beads = ScoopSettings().bead_count_mean
    rng = np.random.default_rng(args.seed)
    rows = []

    def run(index: int, context: np.ndarray, control: np.ndarray, kind: str, k: int,
            seed: int) -> dict:
        key = (index, kind, k, seed)
        if key in done:
            return done[key]
        start = time.process_time()
        result = backend.run_trial("scoop", context, control, seed)
        mean, std = model.predict(context[None], control[None])
        record = {"context_index": index, "kind": kind, "k": k, "seed": seed,
                  "context": context.tolist(), "control": control.tolist(),
                  "score": float(result.score), "valid": bool(result.valid),
                  "phi": float(mean[0] / std[0]),
                  "fraction": result.info.get("fraction_of_capacity"),
                  "capacity": result.info.get("spoon_capacity"),
                  "cpu_s": time.process_time() - start}
        with args.out.open("a") as out:
            out.write(json.dumps(record) + "\n")
        done[key] = record
        return record

    try:
        for index, context_list, theta_list, theta_score in failed_theta_star(args.eval):
            context, theta = np.asarray(context_list), np.asarray(theta_list)
            repeats = [run(index, context, theta, "theta_star", 0, 10_000 * index + 500 + j)
                       for j in range(args.repeats)]
            unit = 2.0 * (theta - lows) / (highs - lows) - 1.0
            local: list[np.ndarray] = []
            while len(local) < args.local:
                batch = np.clip(unit + rng.normal(0.0, args.radius, (64, len(unit))), -1, 1)
                batch = lows + (batch + 1.0) / 2.0 * (highs - lows)
                ok = np.asarray(backend.is_valid("scoop", context, batch), dtype=bool)
                local.extend(batch[ok][: args.local - len(local)])
            local_runs = [run(index, context, control, "local", k, 10_000 * index + k)
                          for k, control in enumerate(local)]
            scores = [r["score"] if r["valid"] else -1.0 for r in local_runs]
            best = int(np.argmax(scores))
            verified = [run(index, context, local[best], "verify", best,
                            10_000 * index + 900 + j) for j in range(args.verify_seeds)]
            head = SpoonDims(float(context[3])).head()
            row = {
                "context_index": index, "context": context.tolist(),
                "bed_depth_est_m": bed_depth_m(context, beads),
                "spoon_head_depth_m": head.height, "spoon_head_diameter_m": head.top_diameter,
                "theta_star_phi": float(np.divide(*model.predict(context[None],
                                                                  theta[None]))[0]),
                "theta_star_scores": [theta_score] + [r["score"] for r in repeats],
                "local_successes": int(sum(s > 0 for s in scores)), "local": len(scores),
                "local_best_score": scores[best], "local_best_control": local[best].tolist(),
                "local_best_phi": local_runs[best]["phi"],
                "local_best_verify_scores": [r["score"] for r in verified],
                "local_mean_fraction": float(np.mean([r["fraction"] or 0.0
                                                      for r in local_runs])),
            }
            rows.append(row)
            print(json.dumps({k: v for k, v in row.items() if k != "local_best_control"}),
                  flush=True)
    finally:
        backend.close()
    args.summary.parent.mkdir(parents=True, exist_ok=True)
    args.summary.write_text(json.dumps({"model": str(args.model), "eval": str(args.eval),
                                        "radius": args.radius, "contexts": rows}, indent=1)
                            + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
