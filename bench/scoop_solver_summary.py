"""Which PyBullet scoop setting is the reference? One summary from the committed caches.

Issues #20/#21: the reference implementation runs PyBullet at its defaults (1/240 s, 50
solver iterations); ltamp's scoop shipped 5. This reads, without simulating anything,

* the fidelity rows' trials (``--cache``, ``bench/fidelity.py``'s ``3d-scoop-solver`` and
  ``3d-scoop-engine`` rows on the inputs of ``--inputs``), and
* the label-stability trials (``--stability-cache``, ``bench/label_stability.py``: the same
  inputs with the control shifted by ``--shifts``),

and writes one JSON (``--out``) with, per comparison, n, agreement with its 95 % Wilson
interval, both / either successes, the disagreements by direction with an exact two-sided
sign test of their direction (a one-sided excess is a bias, not label noise, which flips
both ways), and CPU seconds per trial; then each setting's self-agreement under the shifts
on the random subset (the noise ceiling of any agreement with it) and on the disagreeing
inputs. The committed summary::

    .venv/bin/python bench/scoop_solver_summary.py \
        --out docs/results/fidelity/scoop_solver.json
"""

from __future__ import annotations

import argparse
import json
import math
import platform
from pathlib import Path

import numpy as np

from bench.fidelity import is_success, load_cache, wilson_interval
from bench.label_stability import (
    Plan,
    choose_inputs,
    labels_of,
    load_inputs,
    parse_shift,
    stability,
)
from ltamp_cli.backends.skills3d.scoop import SCOOP_SPEC

FIDELITY = Path(__file__).resolve().parents[1] / "docs" / "results" / "fidelity"
#: The cache-key names the committed trials were simulated under (setting@physics version):
#: read by these names, so the summary means the same after a later physics revision (e.g.
#: the scoop's ``pybullet`` at 50 iterations, ``pybullet@v1.1``) re-keys today's settings.
KEY_NAMES = {"pybullet": "pybullet@v1", "pybullet-solver-50": "pybullet-solver-50@v1",
             "pybullet-solver-20": "pybullet-solver-20@v1", "sapien": "sapien@v3"}
#: (fast, reference) comparisons, as bench/fidelity.py names the settings.
PAIRS = (("pybullet", "pybullet-solver-50"), ("sapien", "pybullet-solver-50"),
         ("sapien", "pybullet"), ("pybullet-solver-20", "pybullet-solver-50"),
         ("pybullet-solver-20", "pybullet"))


def sign_test(k: int, n: int) -> float:
    """Two-sided exact binomial p-value of ``k`` of ``n`` disagreements going one way
    (under p = 1/2: noise flips labels both ways alike)."""
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(max(k, n - k), n + 1)) / 2.0 ** n
    return min(1.0, 2.0 * tail)


def compare(cache: dict[str, dict], inputs: np.ndarray, seed: int, fast: str, reference: str,
            indices: list[int]) -> dict:
    """Agreement of two settings' labels as drawn on the inputs ``indices`` that both have."""
    plan = Plan(SCOOP_SPEC, seed, inputs, [fast, reference], frozenset(), [], KEY_NAMES)
    pairs = []
    for i in indices:
        records = [cache.get(plan.key(s, i, plan.split(i)[1])) for s in (fast, reference)]
        if all(r is not None and r["error"] is None for r in records):
            pairs.append((i, *records))
    f = np.array([is_success(a) for _, a, _ in pairs], dtype=bool)
    r = np.array([is_success(b) for _, _, b in pairs], dtype=bool)
    n, agree = len(pairs), int((f == r).sum())
    fast_only, ref_only = int((f & ~r).sum()), int((~f & r).sum())
    low, high = wilson_interval(agree, n)
    return {"fast": fast, "reference": reference, "n": n, "agree": agree,
            "agreement": agree / n if n else None, "wilson95": [low, high],
            "passes_0.95_rule": bool(n and low >= 0.95),
            "fast_success": float(f.mean()) if n else None,
            "reference_success": float(r.mean()) if n else None,
            "both_success": int((f & r).sum()), "either_success": int((f | r).sum()),
            "fast_only": fast_only, "reference_only": ref_only,
            "sign_test_p": sign_test(max(fast_only, ref_only), fast_only + ref_only),
            "fast_cpu_s": float(np.mean([a["cpu_s"] for _, a, _ in pairs])) if n else None,
            "reference_cpu_s": float(np.mean([b["cpu_s"] for _, _, b in pairs])) if n else None,
            "disagreeing_inputs": [i for (i, _, _), a, b in zip(pairs, f, r, strict=True)
                                   if a != b]}


def stratified(cache: dict[str, dict], inputs: np.ndarray, seed: int, setting: str,
               shifts: list, bad: list[int], chosen: list[int], n: int) -> dict:
    """Per shift, the share of all ``n`` inputs whose ``setting`` label survives it, from two
    strata: the disagreeing inputs ``bad`` (measured, counted as they are) and the others,
    whose rate is that of the random inputs ``chosen`` outside ``bad`` (``range``: with that
    rate at its 95 % Wilson ends). A point estimate with a range, not a test."""
    plan = Plan(SCOOP_SPEC, seed, inputs, [setting], frozenset(), shifts, KEY_NAMES)
    kept_bad, labels_bad, _ = labels_of(plan, cache, setting, bad)
    others = [i for i in chosen if i not in set(bad)]
    kept_other, labels_other, _ = labels_of(plan, cache, setting, others)
    out: dict = {"disagreeing_measured": len(kept_bad), "others_measured": len(kept_other)}
    if len(kept_bad) < len(bad) or not kept_other:
        return out
    for j, shift in enumerate(shifts):
        flips_bad = int((labels_bad[:, j + 1] != labels_bad[:, 0]).sum())
        same = int((labels_other[:, j + 1] == labels_other[:, 0]).sum())
        low, high = wilson_interval(same, len(kept_other))
        rest = n - len(bad)
        out[shift.label] = {
            "estimate": (len(bad) - flips_bad + rest * same / len(kept_other)) / n,
            "range": [(len(bad) - flips_bad + rest * low) / n,
                      (len(bad) - flips_bad + rest * high) / n],
            "disagreeing_kept": len(bad) - flips_bad, "others_kept": same}
    out["mean_over_shifts"] = float(np.mean([out[s.label]["estimate"] for s in shifts]))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--inputs", type=Path, default=FIDELITY / "engine_scoop_inputs.json")
    parser.add_argument("--trials", type=int, default=200)
    parser.add_argument("--cache", type=Path, default=FIDELITY / "engine_scoop_bed_trials.jsonl")
    parser.add_argument("--stability-cache", type=Path,
                        default=FIDELITY / "scoop_stability_trials.jsonl")
    parser.add_argument("--shifts", nargs="*", default=["scoop_z:-0.1", "scoop_z:+0.1"])
    parser.add_argument("--random", type=int, default=40, help="the random subset's size")
    parser.add_argument("--subset-seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=FIDELITY / "scoop_solver.json")
    args = parser.parse_args(argv)
    skill, seed, inputs = load_inputs(args.inputs, args.trials)
    cache = {**load_cache(args.cache), **load_cache(args.stability_cache)}
    everything = list(range(args.trials))
    rows = {f"{f} vs {r}": compare(cache, inputs, seed, f, r, everything) for f, r in PAIRS}
    disagreeing = rows["pybullet vs pybullet-solver-50"]["disagreeing_inputs"]
    bad, chosen = choose_inputs(args.trials, disagreeing, args.random, args.subset_seed)
    shifts = [parse_shift(s, SCOOP_SPEC) for s in args.shifts]
    names = [s.label for s in shifts]
    noise: dict = {}
    for setting in ("pybullet-solver-50", "pybullet"):
        plan = Plan(SCOOP_SPEC, seed, inputs, [setting], frozenset(), shifts, KEY_NAMES)
        noise[setting] = {}
        for group, indices in (("random", chosen), ("disagreeing", bad)):
            kept, labels, cpu = labels_of(plan, cache, setting, indices)
            noise[setting][group] = {
                "inputs": len(indices), "measured": len(kept), **stability(labels, names),
                "unstable_inputs": [i for i, row in zip(kept, labels, strict=True)
                                    if not (row == row[0]).all()],
                "cpu_s_per_trial": float(np.mean(cpu)) if cpu else None}
    for setting in noise:
        noise[setting]["stratified_all_inputs"] = stratified(
            cache, inputs, seed, setting, shifts, bad, chosen, args.trials)
    screen = sorted(set(bad) | set(chosen))
    summary = {
        "skill": skill, "trials": args.trials, "seed": seed, "machine": platform.platform(),
        "rows_all_inputs": rows,
        "screen_inputs": {"disagreeing": bad, "random": chosen,
                          "subset_seed": args.subset_seed},
        "rows_screen": {f"{f} vs {r}": compare(cache, inputs, seed, f, r, screen)
                        for f, r in PAIRS},
        "rows_random_subset": {f"{f} vs {r}": compare(cache, inputs, seed, f, r, chosen)
                               for f, r in PAIRS},
        "label_stability": {"shifts": names, **noise},
    }
    args.out.write_text(json.dumps(summary, indent=1))
    for name, row in rows.items():
        if row["n"]:
            low, high = row["wilson95"]
            print(f"{name:<40} n={row['n']:>3} agree {row['agree']}/{row['n']} "
                  f"{row['agreement']:.3f} ({low:.3f}-{high:.3f}) f-only {row['fast_only']} "
                  f"r-only {row['reference_only']} sign p={row['sign_test_p']:.3g} "
                  f"both/either {row['both_success']}/{row['either_success']} "
                  f"cpu {row['fast_cpu_s']:.2f}/{row['reference_cpu_s']:.2f}")
    for setting, groups in noise.items():
        for group, s in groups.items():
            if "robust" in s:
                r = s["robust"]
                print(f"stability {setting:<20} {group:<12} robust {r['count']}/{r['n']} "
                      f"({r['wilson95'][0]:.3f}-{r['wilson95'][1]:.3f}) self-agreement "
                      + "  ".join(f"{k} {v['count']}/{v['n']}"
                                  for k, v in s["self_agreement"].items()))
    for setting, groups in noise.items():
        for name, value in groups["stratified_all_inputs"].items():
            if name == "mean_over_shifts":
                print(f"stratified {setting:<20} mean over shifts: {value:.3f}")
            if isinstance(value, dict):
                print(f"stratified {setting:<20} {name}: {value['estimate']:.3f} "
                      f"({value['range'][0]:.3f}-{value['range'][1]:.3f})")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
