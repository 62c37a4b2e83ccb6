"""Extend the shipped Kitchen2D pour model with trials in the coffee task's cup sizes.

``ltamp train pour --backend box2d --strategy lse2`` draws each trial's context uniformly from
the skill's whole context box (cups 3–8 wide, 3–5 high), so after 300 trials the model was
still unsure about the small cups of ``problems/kitchen2d/coffee.yaml`` (its most confident
control there had μ/σ ≈ 1, far below β* ≈ 3.5, and half of the executed coffee pours missed).
This script resumes the same ``lse2`` run (same trials file, same seeded trial numbering) but
draws the contexts of the *new* trials from the coffee scene's cup sizes, slightly widened:
the straddle then spends the extra budget on the level set's boundary where the planner needs
it. The model still covers the whole context box (it keeps the first 300 trials).

    OMP_NUM_THREADS=1 .venv/bin/python models/kitchen2d/train_coffee_pour.py --budget 450

It writes ``models/kitchen2d/pour`` (``model.json``, ``weights.npz``, ``trials.jsonl``); a rerun
resumes from ``trials.jsonl``.
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

#: Context ranges of the coffee pour (source = the cream cup, target = the coffee cup), from
#: ``problems/kitchen2d/coffee.yaml`` widened by about 0.2 on each side:
#: ``(cup_width, cup_height, target_width, target_height)`` lows and highs, world units.
COFFEE_LOWS = (3.0, 3.0, 3.6, 3.0)
COFFEE_HIGHS = (4.0, 3.7, 4.6, 3.8)


class CoffeeContexts:
    """A skill backend that forwards everything to ``backend`` except ``sample_context`` of
    the pour, which draws uniformly from the coffee ranges above."""

    def __init__(self, backend: Any) -> None:
        self.backend = backend
        self.name = backend.name

    def skills(self) -> Mapping[str, Any]:
        return self.backend.skills()

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        if skill != "pour":
            return self.backend.sample_context(skill, rng)
        return rng.uniform(COFFEE_LOWS, COFFEE_HIGHS)

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return self.backend.is_valid(skill, context, controls)

    def run_trial(self, skill: str, context: np.ndarray, control: np.ndarray, seed: int,
                  observer: Any = None) -> Any:
        return self.backend.run_trial(skill, context, control, seed, observer)

    def close(self) -> None:
        self.backend.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=int, default=450, help="total trials (old + new)")
    parser.add_argument("--out", type=Path, default=HERE / "pour")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    import torch

    from ltamp_cli.backends import load_backend
    from ltamp_cli.learning.active import LearningConfig, learn_online
    from ltamp_cli.learning.confidence import beta_star
    from ltamp_cli.trials.record import TrialDataset

    torch.set_num_threads(1)
    config = LearningConfig(strategy="lse2", kernel="matern52", budget=args.budget, init=10,
                            seed=args.seed)
    backend = CoffeeContexts(load_backend("box2d"))
    dataset = TrialDataset(args.out / "trials.jsonl")
    before = len(dataset.read()) if dataset.exists() else 0
    result = learn_online(backend, "pour", config, dataset, progress=sys.stderr.isatty())
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
            "init": 10,
            "seed": args.seed,
            "trials_file": "trials.jsonl",
            "contexts": {
                "first_300": "uniform over the skill's context box (ltamp train)",
                "after_300": {"lows": list(COFFEE_LOWS), "highs": list(COFFEE_HIGHS),
                              "script": "models/kitchen2d/train_coffee_pour.py"},
            },
        },
        beta={"lambda": 0.95, "delta": 0.05, "beta_star_50": beta_star(0.05, count=50)},
        curve=[],
    )
    new = records[before:]
    print(json.dumps({"model": str(args.out), "n_trials": len(records), "new_trials": len(new),
                      "new_successes": sum(r.score > 0 for r in new)}))


if __name__ == "__main__":
    main()
