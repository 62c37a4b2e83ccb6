"""Does the Kitchen2D scoop's success depend on its context (the cup's width and height)?

Two measurements (issue #20):

1. **A fixed good control across contexts.** ``CONTROL`` (tilted into the bed, sweep left,
   turn upright low, lift) runs ``--seeds`` times (grain jitter) in every context of a grid
   over the context box; the table gives each context's success rate with its 95 % Wilson
   interval. Context matters when some intervals are disjoint.
2. **A GP fitted on recorded trials** (``--trials``, JSONL trial files such as a model's
   ``trials.jsonl`` or the fidelity bench's cache, whose shipped-setting ``box2d`` records are
   used; at least ``--min-trials``): Matérn-5/2 ARD on inputs normalised to [−1, 1], fitted by
   maximum marginal likelihood. A context lengthscale at the upper bound (20) would say the
   context is irrelevant; below it, the score varies with the context.

Results go to ``--out`` (JSON) and a table on stdout.

    OMP_NUM_THREADS=1 .venv/bin/python bench/scoop_context.py \
        --trials models/kitchen2d/scoop/trials.jsonl bench/results/fidelity_2d_scoop_trials.jsonl
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy.stats import binomtest

from ltamp_cli.backends.box2d.backend import Kitchen2DBackend
from ltamp_cli.learning.gp import HyperBounds, fit_gp
from ltamp_cli.learning.normalize import BoxNormalizer, join_inputs, joint_space

ROOT = Path(__file__).resolve().parents[1]
#: A control that scoops in mid-size cups (tests/box2d/test_scoop.py uses it too).
CONTROL = (0.59, 0.02, 0.84, -0.48, 0.51, 0.51, 0.15)
WIDTHS = (5.0, 6.25, 7.5, 8.75, 10.0)
HEIGHTS = (4.0, 6.0, 8.0)


def wilson(successes: int, n: int) -> tuple[float, float]:
    ci = binomtest(successes, n).proportion_ci(confidence_level=0.95, method="wilson")
    return float(ci.low), float(ci.high)


def fixed_control_rates(backend: Kitchen2DBackend, seeds: int) -> list[dict]:
    """Success of ``CONTROL`` in each grid context over ``seeds`` trial seeds."""
    control = np.array(CONTROL)
    rows = []
    for width in WIDTHS:
        for height in HEIGHTS:
            context = np.array([width, height])
            start = time.process_time()
            scores = [backend.run_trial("scoop", context, control, seed).score
                      for seed in range(seeds)]
            wins = sum(score > 0 for score in scores)
            low, high = wilson(wins, seeds)
            rows.append({"context": [width, height], "successes": wins, "n": seeds,
                         "rate": wins / seeds, "wilson95": [low, high],
                         "mean_score": float(np.mean(scores)),
                         "cpu_s_per_trial": (time.process_time() - start) / seeds})
            print(f"  cup {width:5.2f} x {height:4.1f}: {wins:2d}/{seeds} "
                  f"[{low:.2f}, {high:.2f}]", file=sys.stderr, flush=True)
    return rows


def read_trials(paths: list[Path]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Contexts ``(n, 2)``, controls ``(n, 7)`` and scores ``(n,)`` of the valid shipped-
    setting scoop trials in ``paths`` (duplicates by context + control dropped)."""
    seen: set[tuple[float, ...]] = set()
    contexts, controls, scores = [], [], []
    for path in paths:
        for line in path.read_text().splitlines():
            record = json.loads(line)
            if record.get("skill") != "scoop" or record.get("setting", "box2d") != "box2d":
                continue
            if not record.get("valid", False):
                continue
            key = tuple(record["context"]) + tuple(record["control"])
            if key in seen:
                continue
            seen.add(key)
            contexts.append(record["context"])
            controls.append(record["control"])
            scores.append(record["score"])
    return np.array(contexts), np.array(controls), np.array(scores)


def fit_lengthscales(backend: Kitchen2DBackend, paths: list[Path]) -> dict:
    spec = backend.skills()["scoop"]
    contexts, controls, scores = read_trials(paths)
    normalizer = BoxNormalizer.for_space(joint_space(spec))
    x = normalizer.to_unit(join_inputs(spec, contexts, controls))
    start = time.process_time()
    gp = fit_gp(x, scores, "matern52", rng=np.random.default_rng(0))
    names = [*spec.control.names, *spec.context.names]
    bound = HyperBounds().lengthscale[1]
    lengthscales = dict(zip(names, map(float, gp.lengthscales), strict=True))
    return {"n_trials": len(scores), "successes": int((scores > 0).sum()),
            "lengthscales": lengthscales, "upper_bound": bound,
            "context_below_bound": all(lengthscales[name] < 0.95 * bound
                                       for name in spec.context.names),
            "fit_cpu_s": time.process_time() - start}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=10, help="trials per grid context")
    parser.add_argument("--trials", type=Path, nargs="*", default=[],
                        help="JSONL trial files for the GP fit")
    parser.add_argument("--min-trials", type=int, default=500)
    parser.add_argument("--out", type=Path,
                        default=ROOT / "docs" / "results" / "scoop_context.json")
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")
    backend = Kitchen2DBackend()
    report: dict = {"control": list(CONTROL)}
    if args.trials:
        fit = fit_lengthscales(backend, args.trials)
        if fit["n_trials"] < args.min_trials:
            parser.error(f"only {fit['n_trials']} valid trials (need {args.min_trials})")
        report["gp"] = fit
    report["fixed_control"] = fixed_control_rates(backend, args.seeds)
    rows = report["fixed_control"]
    lowest = min(rows, key=lambda r: r["rate"])
    highest = max(rows, key=lambda r: r["rate"])
    report["disjoint"] = highest["wilson95"][0] > lowest["wilson95"][1]
    print(f"fixed control {CONTROL}, {args.seeds} seeds per context")
    print(f"{'cup w':>6} {'cup h':>6} {'success':>8} {'wilson95':>14}")
    for row in rows:
        w, h = row["context"]
        print(f"{w:6.2f} {h:6.1f} {row['rate']:8.2f} "
              f"{row['wilson95'][0]:6.2f}-{row['wilson95'][1]:.2f}")
    print(f"best {highest['context']} vs worst {lowest['context']}: intervals disjoint: "
          f"{report['disjoint']}")
    if "gp" in report:
        fit = report["gp"]
        print(f"GP on {fit['n_trials']} trials ({fit['successes']} successes), lengthscales "
              f"(bound {fit['upper_bound']:.0f}):")
        for name, value in fit["lengthscales"].items():
            print(f"  {name:12s} {value:7.3f}")
        print(f"context lengthscales below the bound: {fit['context_below_bound']}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=2) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
