"""Shipped 2D models refitted with the GP lengthscale prior (issue #21): paired θ* success.

The shipped Kitchen2D models (``models/kitchen2d/{pour,scoop,push}``) were fitted by maximum
marginal likelihood, before the lengthscale prior became the default fit. Each was refitted on
its own ``trials.jsonl`` with ``ltamp train SKILL --out DIR --refit`` (no trial run) and both
versions evaluated with ``ltamp evaluate DIR --trials 20 --seed S --json`` (S = 0, 1): one live
trial of θ* per context, the contexts drawn from the seed alone, so the old and the refitted
model meet the same 40 contexts per skill (checked here) and the same trial seeds.

``python -m bench.gpprior_refit2d --evals DIR --old MODELS_OLD --new MODELS_NEW`` reads
``DIR/{old,new}-{skill}-seed{S}.json`` (``ltamp evaluate --json`` outputs; the per-context
``successes`` list), the two model directories' hyperparameters, prints per skill the θ* rates
with Wilson 95 % intervals, the paired comparison refit − old over the 40 contexts (exact
McNemar test = two-sided sign test on the discordant contexts; bootstrap interval of the mean
difference) and the hyperparameters side by side, and writes ``--out`` (JSON). ``--new``
defaults to ``models/kitchen2d``, where the pour and push refits are shipped; the scoop refit
was not shipped (worse), so reproducing the table needs ``--new`` pointing at refitted copies
of all three.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.learning.metrics import wilson_interval

REPO = Path(__file__).resolve().parents[1]
SKILLS = ("pour", "scoop", "push")
SEEDS = (0, 1)


def _read(path: Path) -> dict[str, Any]:
    if not path.is_file():
        raise FileNotFoundError(f"missing evaluation {path}")
    return json.loads(path.read_text())


def report(evals: Path, old: Path, new: Path, out: Path) -> dict[str, Any]:
    """Per skill: θ* and random rates (old, refit), paired refit − old, hyperparameters."""
    from scipy.stats import binomtest

    from bench.paper.stats import paired_comparison

    summary: dict[str, Any] = {}
    for skill in SKILLS:
        rows: dict[str, list[int]] = {"old": [], "new": [], "random": []}
        cpu: dict[str, float] = {}
        for seed in SEEDS:
            a = _read(evals / f"old-{skill}-seed{seed}.json")
            b = _read(evals / f"new-{skill}-seed{seed}.json")
            if a["contexts"] != b["contexts"]:
                raise ValueError(f"{skill} seed {seed}: the two evaluations' contexts differ")
            if a["random_successes"] != b["random_successes"]:
                raise ValueError(f"{skill} seed {seed}: the random baselines differ")
            rows["old"] += a["successes"]
            rows["new"] += b["successes"]
            rows["random"] += a["random_successes"]
            for name in ("old", "new"):
                timing = evals / f"{name}-{skill}-seed{seed}.json.time"
                if timing.is_file():
                    user, system = map(float, timing.read_text().split()[:2])
                    cpu[f"{name}_seed{seed}"] = round(user + system, 1)
        n = len(rows["old"])
        both = sum(1 for x, y in zip(rows["old"], rows["new"], strict=True) if x and y)
        only_new = sum(1 for x, y in zip(rows["old"], rows["new"], strict=True) if y and not x)
        only_old = sum(1 for x, y in zip(rows["old"], rows["new"], strict=True) if x and not y)
        discordant = only_new + only_old
        mcnemar = (float(binomtest(only_new, discordant).pvalue) if discordant else 1.0)
        comparison = paired_comparison("refit", rows["new"], "shipped", rows["old"])
        hyper = {name: json.loads((directory / skill / "model.json").read_text())
                 ["hyperparameters"] for name, directory in (("old", old), ("new", new))}
        summary[skill] = {
            "n_contexts": n,
            "per_seed": {str(seed): {"old": sum(rows["old"][i * 20:(i + 1) * 20]),
                                     "new": sum(rows["new"][i * 20:(i + 1) * 20]),
                                     "random": sum(rows["random"][i * 20:(i + 1) * 20])}
                         for i, seed in enumerate(SEEDS)},
            "old": {"successes": sum(rows["old"]), "rate": sum(rows["old"]) / n,
                    "wilson95": [round(x, 3) for x in wilson_interval(sum(rows["old"]), n)]},
            "new": {"successes": sum(rows["new"]), "rate": sum(rows["new"]) / n,
                    "wilson95": [round(x, 3) for x in wilson_interval(sum(rows["new"]), n)]},
            "random": {"successes": sum(rows["random"]), "rate": sum(rows["random"]) / n,
                       "wilson95": [round(x, 3) for x in wilson_interval(sum(rows["random"]), n)]},
            "paired": {"both": both, "only_refit": only_new, "only_shipped": only_old,
                       "mcnemar_exact_p": mcnemar, "text": comparison.describe(),
                       "verdict": comparison.verdict},
            "hyperparameters": hyper,
            "evaluate_cpu_s": cpu,
        }
    payload = {"experiment": "shipped 2D models refitted with the lengthscale prior (issue #21)",
               "commands": {"refit": "ltamp train SKILL --out DIR --refit",
                            "evaluate": "ltamp evaluate DIR --trials 20 --seed S --json"},
               "summary": summary}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(payload, indent=1) + "\n")
    print(f"{'skill':6} {'shipped θ*':22} {'refit θ*':22} {'random':22} both/only refit/"
          "only shipped  McNemar p")
    for skill, entry in summary.items():
        cells = []
        for name in ("old", "new", "random"):
            row = entry[name]
            low, high = row["wilson95"]
            cells.append(f"{row['successes']:2d}/{entry['n_contexts']} [{low:.2f}, {high:.2f}]")
        paired = entry["paired"]
        print(f"{skill:6} {cells[0]:22} {cells[1]:22} {cells[2]:22} "
              f"{paired['both']}/{paired['only_refit']}/{paired['only_shipped']}"
              f"{'':14}{paired['mcnemar_exact_p']:.3g}")
    for skill, entry in summary.items():
        old_h, new_h = entry["hyperparameters"]["old"], entry["hyperparameters"]["new"]
        print(f"\n{skill}: lengthscales shipped {np.round(old_h['lengthscales'], 2).tolist()}")
        print(f"{'':6} lengthscales refit   {np.round(new_h['lengthscales'], 2).tolist()}")
        for key in ("outputscale", "noise", "mean"):
            print(f"{'':6} {key}: {old_h[key]:.4g} -> {new_h[key]:.4g}")
    return payload


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.gpprior_refit2d",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--evals", type=Path,
                        default=REPO / "docs" / "results" / "learning" / "refit2d")
    parser.add_argument("--old", type=Path, required=True,
                        help="directory holding the shipped models (pour/, scoop/, push/)")
    parser.add_argument("--new", type=Path, default=REPO / "models" / "kitchen2d",
                        help="directory holding the refitted models")
    parser.add_argument("--out", type=Path,
                        default=REPO / "docs" / "results" / "learning" / "refit2d.json")
    args = parser.parse_args(argv)
    try:
        report(args.evals, args.old, args.new, args.out)
    except (FileNotFoundError, ValueError, KeyError) as error:
        print(f"bench.gpprior_refit2d: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
