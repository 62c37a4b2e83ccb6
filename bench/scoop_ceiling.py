"""Is a context's scoop hard for any control, or only for θ*? Random valid controls per context.

For each context given (default: the contexts where θ* of ``models/kitchen3d/scoop`` failed in
``docs/results/scoop3d/eval_trials.jsonl``), this runs ``--controls`` uniformly random
pre-check-valid controls on ``--backend`` (default ``sapien``: ~0.9 s CPU per scoop trial
against PyBullet's ~4 s, label agreement with PyBullet in ``docs/results/fidelity/engine.json``)
and reports how many succeed and the best score; with ``--verify`` the best control of each
context is re-run on PyBullet (the shipped models' ground truth) with ``--verify-seeds`` trial
seeds. One JSON line per trial is appended to ``--out`` as it finishes; a rerun skips the
trials already there.

    OMP_NUM_THREADS=1 .venv/bin/python bench/scoop_ceiling.py --controls 30 --verify \
        --out docs/results/scoop3d/ceiling_trials.jsonl
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from ltamp_cli.backends import load_backend

ROOT = Path(__file__).resolve().parents[1]


def failing_contexts(path: Path) -> list[list[float]]:
    """Contexts whose θ* trial (the first record of each seed) failed, in file order."""
    seen: dict[int, dict] = {}
    for line in path.open():
        record = json.loads(line)
        seen.setdefault(record["seed"], record)
    return [r["context"] for r in seen.values() if not (r["valid"] and r["score"] > 0)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--eval", type=Path,
                        default=ROOT / "docs/results/scoop3d/eval_trials.jsonl")
    parser.add_argument("--controls", type=int, default=30)
    parser.add_argument("--backend", default="sapien")
    parser.add_argument("--verify", action="store_true")
    parser.add_argument("--verify-seeds", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    if args.controls < 1:
        print("scoop_ceiling: --controls must be >= 1", file=sys.stderr)
        return 2
    done = set()
    if args.out.exists():
        done = {(r["context_index"], r["backend"], r["control_index"], r["seed"])
                for r in map(json.loads, args.out.open())}
    contexts = failing_contexts(args.eval)
    backend = load_backend(args.backend)
    spec = backend.skills()["scoop"]
    rng = np.random.default_rng(args.seed)
    summary = []
    try:
        for c_index, context in enumerate(contexts):
            context = np.asarray(context)
            controls: list[np.ndarray] = []
            while len(controls) < args.controls:
                for control in spec.control.sample_uniform(rng, 64):
                    if backend.is_valid("scoop", context, control[None])[0]:
                        controls.append(control)
                        if len(controls) == args.controls:
                            break
            scores = []
            for k, control in enumerate(controls):
                seed = 1000 * c_index + k
                key = (c_index, args.backend, k, seed)
                start = time.process_time()
                if key in done:
                    record = next(r for r in map(json.loads, args.out.open())
                                  if (r["context_index"], r["backend"], r["control_index"],
                                      r["seed"]) == key)
                else:
                    result = backend.run_trial("scoop", context, control, seed)
                    record = {"context_index": c_index, "backend": args.backend,
                              "control_index": k, "seed": seed, "context": context.tolist(),
                              "control": control.tolist(), "score": float(result.score),
                              "valid": bool(result.valid),
                              "cpu_s": time.process_time() - start}
                    with args.out.open("a") as out:
                        out.write(json.dumps(record) + "\n")
                scores.append(record["score"] if record["valid"] else -1.0)
            best = int(np.argmax(scores))
            row = {"context_index": c_index, "context": context.tolist(),
                   "successes": int(sum(s > 0 for s in scores)), "controls": len(scores),
                   "best_score": scores[best], "best_control": controls[best].tolist()}
            if args.verify:
                bullet = load_backend("pybullet")
                try:
                    verified = []
                    for j in range(args.verify_seeds):
                        seed = 1000 * c_index + 900 + j
                        result = bullet.run_trial("scoop", context, controls[best], seed)
                        verified.append(float(result.score))
                        with args.out.open("a") as out:
                            out.write(json.dumps({
                                "context_index": c_index, "backend": "pybullet",
                                "control_index": best, "seed": seed,
                                "context": context.tolist(),
                                "control": controls[best].tolist(),
                                "score": float(result.score), "valid": bool(result.valid)})
                                + "\n")
                finally:
                    bullet.close()
                row["best_on_pybullet"] = verified
            summary.append(row)
            print(json.dumps({k: v for k, v in row.items() if k != "best_control"}), flush=True)
    finally:
        backend.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
