"""The 3D push with its goal as a pure goal (issue #20/#21): θ* of a push model on an engine.

``python bench/push3d_goal.py --model docs/results/push/push3d/model --engine sapien
--trials 50 --seed 0 --out docs/results/push/push3d/evaluate_sapien.json`` runs, for the
``--trials`` contexts ``ltamp evaluate --seed S`` draws (the same contexts whatever the
engine), the model's most confident valid control θ* and a uniformly random valid control
once each on ``--engine`` (``pybullet`` or ``sapien``: the skill is defined once,
``ltamp_cli/backends/skills3d/push.py``), and writes the success counts with Wilson 95 %
intervals. A model trained on PyBullet evaluated on SAPIEN checks that what it learned is
the skill's, not one engine's. Times are CPU seconds of this process (shared machine).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from bench.lse2 import _wilson
from ltamp_cli.backends import load_backend
from ltamp_cli.cli.evaluate import _live_outcomes
from ltamp_cli.learning.model import LevelSetModel


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python bench/push3d_goal.py",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", type=Path, required=True)
    parser.add_argument("--engine", choices=("pybullet", "sapien"), required=True)
    parser.add_argument("--trials", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    if args.trials < 1 or not (args.model / "model.json").is_file():
        print(f"error: need --trials >= 1 and a model directory ({args.model})",
              file=sys.stderr)
        return 2
    model = LevelSetModel.load(str(args.model))
    backend = load_backend(args.engine)
    cpu0 = time.process_time()
    try:
        star, baseline, contexts = _live_outcomes(backend, "push", model, args.trials,
                                                  args.seed)
    finally:
        backend.close()
    cpu = time.process_time() - cpu0
    payload = {"model": str(args.model), "engine": args.engine, "seed": args.seed,
               "n_contexts": args.trials, "theta_star": sum(star),
               "theta_star_wilson95": _wilson(sum(star), args.trials),
               "random": sum(baseline), "random_wilson95": _wilson(sum(baseline), args.trials),
               "successes": star, "random_successes": baseline, "contexts": contexts,
               "cpu_s": round(cpu, 1)}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(payload, indent=1) + "\n")
    print(f"3D push on {args.engine}: θ* {sum(star)}/{args.trials} "
          f"{payload['theta_star_wilson95']}, random valid {sum(baseline)}/{args.trials} "
          f"{payload['random_wilson95']}, {cpu:.1f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
