"""Train the Kitchen2D push model on the pushes the kitchen can execute (Task I).

``ltamp train push --backend box2d --strategy lse2`` draws goals from the whole context box
[-5, 5]² and controls from the whole control box. A push that moves the block ~4 units needs
the pusher behind the block, in line with it and aimed at the goal: about 0.2 % of uniform
controls. In 300 such trials no far goal was ever reached (all 32 successes were goals within
2 of the start, "reached" without touching the block), and the model's most confident
control for a goal past the table edge had μ/σ ≈ -5.

This script runs the same ``lse2`` learner (Matérn-5/2 ARD GP, straddle, live Box2D trials
of the unchanged push skill, same score) but

* draws each trial's goal where the kitchen's GoodPush asks (``tamp.push_context``): goal_x in
  ±[3, 5] (the side at random), goal_y in [-0.5, 0.5];
* adds the kitchen's section test (``tamp.section_mask``: pusher behind the block, in line
  with it, running mostly along the table) to the skill's validity test, so the straddle
  proposes only controls the kitchen could execute. The first ``--init`` trials are uniform
  over the whole control box, as in ``ltamp train``.

The model keeps the skill's full spec (contexts and controls in the skill's boxes); it is
simply trained where the planner queries it.

    OMP_NUM_THREADS=1 .venv/bin/python models/kitchen2d/push/train_kitchen.py --budget 150

Writes ``models/kitchen2d/push`` (``model.json``, ``weights.npz``, ``trials.jsonl``); a rerun
with a larger budget resumes from ``trials.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
#: |goal_x| range (world units) and |goal_y| bound of the kitchen's push goals.
GOAL_X = (3.0, 5.0)
GOAL_Y = 0.5


class KitchenPushes:
    """A skill backend forwarding to ``backend``, except for the push: goals drawn where
    the kitchen queries, validity = the skill's test and the kitchen's section test."""

    def __init__(self, backend: Any) -> None:
        self.backend = backend
        self.name = backend.name

    def skills(self) -> Mapping[str, Any]:
        return self.backend.skills()

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        if skill != "push":
            return self.backend.sample_context(skill, rng)
        side = 1.0 if rng.uniform() < 0.5 else -1.0
        return np.array([side * rng.uniform(*GOAL_X), rng.uniform(-GOAL_Y, GOAL_Y)])

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        from ltamp_cli.backends.box2d.tamp import section_mask

        valid = self.backend.is_valid(skill, context, controls)
        return valid & section_mask(context, controls) if skill == "push" else valid

    def run_trial(self, skill: str, context: np.ndarray, control: np.ndarray, seed: int,
                  observer: Any = None) -> Any:
        return self.backend.run_trial(skill, context, control, seed, observer)

    def close(self) -> None:
        self.backend.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=int, default=150, help="total trials")
    parser.add_argument("--init", type=int, default=10, help="uniform trials first")
    parser.add_argument("--out", type=Path, default=HERE)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    import torch

    from ltamp_cli.backends import load_backend
    from ltamp_cli.learning.active import LearningConfig, learn_online
    from ltamp_cli.learning.confidence import beta_star
    from ltamp_cli.trials.record import TrialDataset

    torch.set_num_threads(1)
    config = LearningConfig(strategy="lse2", kernel="matern52", budget=args.budget,
                            init=args.init, seed=args.seed)
    backend = KitchenPushes(load_backend("box2d"))
    dataset = TrialDataset(args.out / "trials.jsonl")
    result = learn_online(backend, "push", config, dataset, progress=sys.stderr.isatty())
    backend.close()
    records = result.records
    result.model.save(
        str(args.out),
        backend="box2d",
        strategy="lse2",
        training={
            "mode": "online",
            "n_trials": len(records),
            "n_valid": sum(r.valid for r in records),
            "n_success": sum(r.score > 0 for r in records),
            "budget": args.budget,
            "init": args.init,
            "seed": args.seed,
            "trials_file": "trials.jsonl",
            "contexts": {"goal_x_abs": list(GOAL_X), "goal_y_abs_max": GOAL_Y},
            "validity": "skill test and tamp.section_mask",
            "script": "models/kitchen2d/push/train_kitchen.py",
        },
        beta={"lambda": 0.95, "delta": 0.05, "beta_star_50": beta_star(0.05, count=50)},
        curve=[],
    )
    print(json.dumps({"model": str(args.out), "n_trials": len(records),
                      "n_success": sum(r.score > 0 for r in records)}))


if __name__ == "__main__":
    main()
