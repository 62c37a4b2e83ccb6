"""``ltamp evaluate``'s live measurement from context ``--start`` on, for a second process.

``ltamp evaluate MODEL --trials N --seed S`` (``_live_success_rates``) draws context k and
θ* with one generator, so context k depends on every earlier θ* search. This script repeats
those draws and searches for the contexts before ``--start`` without running their trials
(the random baseline's 1,000 candidates are drawn but not pre-checked: drawing them does not
depend on the pre-check), then runs θ* and the random baseline exactly as ``ltamp evaluate``
does for contexts ``--start`` .. N-1, one JSON line per trial (with its context index)
appended to ``--log``. Together with a ``bench/kitchen3d_models.py --log`` run stopped after
context ``--start`` - 1 it is the whole measurement, in two processes.

    OMP_NUM_THREADS=1 .venv/bin/python bench/evaluate_shard.py models/kitchen3d/scoop \\
        --trials 20 --start 12 --log docs/results/scoop3d/eval_trials_bed_shard.jsonl

``--only random`` runs only the random baseline's trials (``--only theta_star`` only θ*'s):
the contexts and the baseline's controls do not depend on the model (θ*'s search draws a
fixed number of candidates), so the baseline can run before the model it is compared with
exists (any model of the skill replays the draws), and be combined with a later θ*-only run.

``--combine MAIN.jsonl`` instead merges the stopped ``kitchen3d_models.py`` log (θ* then
random per context, in order) with the ``--log`` files of shards (repeat ``--log``) and writes
the rates with 95 % Wilson intervals to ``--out`` (a context's first record wins).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from ltamp_cli.backends import load_backend
from ltamp_cli.learning.metrics import wilson_interval
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.threads import use_one_thread


def combine(main_log: Path, shards: list[Path], trials: int) -> dict:
    """θ* and random rates over the contexts 0 .. ``trials`` - 1 found in the logs."""
    found: dict[int, dict[str, dict]] = {}
    lines = [json.loads(line) for line in main_log.open() if line.strip()]
    for number, row in enumerate(lines):
        found.setdefault(number // 2, {}).setdefault(
            "theta_star" if number % 2 == 0 else "random", row)
    for shard in shards:
        for line in shard.open():
            if line.strip():
                row = json.loads(line)
                found.setdefault(row["index"], {}).setdefault(row["kind"], row)
    complete = [i for i in range(trials) if len(found.get(i, {})) == 2]
    theta = sum(found[i]["theta_star"]["valid"] and found[i]["theta_star"]["score"] > 0
                for i in complete)
    rand = sum(found[i]["random"]["valid"] and found[i]["random"]["score"] > 0
               for i in complete)
    n = len(complete)
    cpu = [found[i][k]["cpu_s"] for i in complete for k in ("theta_star", "random")]
    return {
        "contexts": n, "missing": [i for i in range(trials) if i not in complete],
        "theta_successes": theta, "theta_rate": theta / n if n else None,
        "theta_wilson95": list(wilson_interval(theta, n)), "random_successes": rand,
        "random_rate": rand / n if n else None, "random_wilson95": list(wilson_interval(rand, n)),
        "gap": (theta - rand) / n if n else None,
        "cpu_s_per_trial_mean": sum(cpu) / len(cpu) if cpu else None,
        "per_context": [{"index": i, "context": found[i]["theta_star"]["context"],
                         "theta_score": found[i]["theta_star"]["score"],
                         "random_score": found[i]["random"]["score"]} for i in complete],
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", type=Path)
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--start", type=int, default=0)
    parser.add_argument("--log", type=Path, action="append", required=True)
    parser.add_argument("--combine", type=Path, help="the stopped kitchen3d_models.py log")
    parser.add_argument("--out", type=Path)
    parser.add_argument("--only", choices=("theta_star", "random"),
                        help="run only this kind of trial (see the module doc)")
    args = parser.parse_args(argv)
    if args.combine is not None:
        summary = combine(args.combine, args.log, args.trials)
        print(json.dumps({k: v for k, v in summary.items() if k != "per_context"}, indent=1))
        if args.out is not None:
            args.out.write_text(json.dumps(summary, indent=1) + "\n")
        return 0
    args.log = args.log[0]
    if not (0 <= args.start < args.trials):
        print("error: --start must be in [0, --trials)", file=sys.stderr)
        return 2
    use_one_thread()
    loaded = load_model(args.model)
    model = loaded.model
    skill = model.spec.name
    physics = load_backend(str(loaded.metadata.get("backend", "pybullet")))
    seed = args.seed
    rng = np.random.default_rng(seed)
    baseline_rng = np.random.default_rng([seed, 1])
    space = physics.skills()[skill].control
    for index in range(args.trials):
        context = physics.sample_context(skill, rng)
        control, _ = model.most_confident_control(
            context, rng, lambda c, u: physics.is_valid(skill, c, u))
        candidates = space.sample_uniform(baseline_rng, 1000)
        if index < args.start:
            continue
        rows = [("theta_star", control)]
        valid = np.flatnonzero(physics.is_valid(skill, context, candidates))
        if len(valid):
            rows.append(("random", candidates[valid[0]]))
        for kind, chosen in rows:
            if args.only is not None and kind != args.only:
                continue
            start = time.process_time()
            result = physics.run_trial(skill, context, chosen, seed=seed * 100_003 + index)
            row = {"skill": skill, "index": index, "kind": kind,
                   "context": np.asarray(context).tolist(),
                   "control": np.asarray(chosen).tolist(), "seed": seed,
                   "score": float(result.score), "valid": bool(result.valid),
                   "cpu_s": time.process_time() - start}
            with args.log.open("a") as out:
                out.write(json.dumps(row) + "\n")
            print(f"{index:3d} {kind:10s} {result.score:+.2f}", flush=True)
    physics.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
