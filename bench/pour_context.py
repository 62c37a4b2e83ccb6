"""Does the 2D pour's success depend on its context (the cup sizes)?

Two measurements, both written to ``--out`` (JSON) and printed as a table:

1. **A fixed control across contexts.** One pour control (``--control``, default a pour
   from the left that succeeds for mid-sized cups) runs once, as shipped, in each of
   ``--contexts`` contexts drawn uniformly over the skill's context box (seeded). The
   table gives the overall success rate and, for each context dimension, the success rate
   of the contexts below and above its median, each with its 95 % Wilson interval, and
   Fisher's exact test of the difference. If success did not depend on the context, no
   split would differ beyond chance.
2. **The learned GP.** The Matérn ARD lengthscales of the model in ``--model`` (fitted on
   its training pool), in normalised units (inputs span [−1, 1]), against the fit's upper
   bound (``HyperBounds.lengthscale``): a context dimension the data showed to be
   irrelevant would run to the bound.

Trials are cached in ``--cache`` (one JSON line each, as ``bench/fidelity.py`` does), so a
stopped run resumes.

    OMP_NUM_THREADS=1 .venv/bin/python bench/pour_context.py --contexts 80
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
from pathlib import Path

import numpy as np
from scipy.stats import fisher_exact

from bench.fidelity import (
    append_record,
    is_success,
    load_cache,
    run_trial,
    trial_key,
    wilson_interval,
)
from ltamp_cli.backends.box2d.backend import Kitchen2DBackend
from ltamp_cli.learning.gp import HyperBounds

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results" / "fidelity"
#: A pour from the left of the target, high, nearly upside down (succeeds for mid cups).
DEFAULT_CONTROL = (0.8, -1.5, 9.8, 3.1)


def fixed_control_rows(backend: Kitchen2DBackend, control: np.ndarray, n: int, seed: int,
                       cache_path: Path, progress: bool) -> list[dict]:
    """Run ``control`` in ``n`` seeded contexts (cached); one record per context."""
    cache = load_cache(cache_path)
    rng = np.random.default_rng(seed)
    records = []
    for index in range(n):
        context = backend.sample_context("pour", rng)
        trial_seed = seed * 100_000 + index
        key = trial_key("box2d", "pour", context, control, trial_seed)
        if key not in cache:
            record = {"key": key, "setting": "box2d", "skill": "pour", "seed": trial_seed,
                      "context": context.tolist(), "control": control.tolist(),
                      **run_trial(backend, "box2d", "pour", context, control, trial_seed)}
            append_record(cache_path, record)
            cache[key] = record
        records.append(cache[key])
        if progress:
            print(f"\rfixed control: {index + 1}/{n}", end="", file=sys.stderr, flush=True)
    if progress:
        print(file=sys.stderr)
    return records


def rate(labels: np.ndarray) -> dict:
    k, n = int(labels.sum()), len(labels)
    low, high = wilson_interval(k, n)
    return {"successes": k, "n": n, "rate": k / n if n else None, "wilson95": [low, high]}


def splits(records: list[dict], names: tuple[str, ...]) -> list[dict]:
    """Success below / above each context dimension's median, with Fisher's exact test."""
    contexts = np.array([r["context"] for r in records])
    labels = np.array([is_success(r) for r in records])
    rows = []
    for dim, name in enumerate(names):
        median = float(np.median(contexts[:, dim]))
        low = contexts[:, dim] <= median
        table = [[int(labels[low].sum()), int((~labels[low]).sum())],
                 [int(labels[~low].sum()), int((~labels[~low]).sum())]]
        rows.append({"dimension": name, "median": median, "below": rate(labels[low]),
                     "above": rate(labels[~low]), "fisher_p": float(fisher_exact(table)[1])})
    return rows


def model_lengthscales(model_dir: Path) -> dict:
    """The model's lengthscales by input name, the fit's bound, and the context ones."""
    meta = json.loads((model_dir / "model.json").read_text())
    scales = dict(zip(meta["input_order"], meta["hyperparameters"]["lengthscales"], strict=True))
    context = meta["skill"]["context"]["names"]
    bound = HyperBounds().lengthscale[1]
    return {"model": str(model_dir), "lengthscales": scales, "bound": bound,
            "context_below_bound": {name: scales[name] < 0.9 * bound for name in context},
            "n_train": meta.get("n_train")}


def print_report(report: dict) -> None:
    overall = report["fixed_control"]["overall"]
    lo, hi = overall["wilson95"]
    print(f"fixed control {report['fixed_control']['control']}: "
          f"{overall['successes']}/{overall['n']} succeed ({lo:.2f}-{hi:.2f})")
    print(f"{'context dim':<14} {'median':>6} {'below: rate (95%)':>22} "
          f"{'above: rate (95%)':>22} {'Fisher p':>9}")
    for row in report["fixed_control"]["splits"]:
        cells = []
        for side in ("below", "above"):
            r = row[side]
            cells.append(f"{r['successes']:>2}/{r['n']:<3} {r['rate']:.2f} "
                         f"({r['wilson95'][0]:.2f}-{r['wilson95'][1]:.2f})")
        print(f"{row['dimension']:<14} {row['median']:>6.2f} {cells[0]:>22} {cells[1]:>22} "
              f"{row['fisher_p']:>9.2g}")
    gp = report["gp"]
    if gp:
        scales = ", ".join(f"{k} {v:.2f}" for k, v in gp["lengthscales"].items())
        print(f"GP lengthscales ({gp['n_train']} trials; bound {gp['bound']:g}): {scales}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--contexts", type=int, default=80, help="contexts drawn")
    parser.add_argument("--control", type=float, nargs=4, default=DEFAULT_CONTROL,
                        metavar=("RATIO", "REL_X", "REL_Y", "DANGLE"))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--model", type=Path, default=ROOT / "models" / "kitchen2d" / "pour")
    parser.add_argument("--cache", type=Path, default=RESULTS / "pour_context_trials.jsonl")
    parser.add_argument("--out", type=Path, default=RESULTS / "pour_context.json")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    if args.contexts < 2:
        parser.error("--contexts must be at least 2")
    args.cache.parent.mkdir(parents=True, exist_ok=True)
    backend = Kitchen2DBackend()
    control = np.array(args.control, dtype=float)
    if not np.all((control >= backend.skills()["pour"].control.lows)
                  & (control <= backend.skills()["pour"].control.highs)):
        parser.error("--control is outside the pour's control box")
    records = fixed_control_rows(backend, control, args.contexts, args.seed, args.cache,
                                 not args.quiet)
    names = backend.skills()["pour"].context.names
    labels = np.array([is_success(r) for r in records])
    report = {
        "machine": platform.platform(), "seed": args.seed,
        "fixed_control": {"control": control.tolist(), "overall": rate(labels),
                          "valid": int(sum(r["valid"] for r in records)),
                          "splits": splits(records, names)},
        "gp": model_lengthscales(args.model) if (args.model / "model.json").exists() else None,
    }
    print_report(report)
    args.out.write_text(json.dumps(report, indent=1))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
