"""Paired comparison of two ``bench/planner.py`` (or ``bench/planner_hidden.py``) result files
(before / after a change).

Runs are paired by (example, algorithm, history, seed). Per (example, algorithm, history):
solved before / after with the Wilson 95 % interval of the after rate, median CPU seconds
before and after, the median of the paired differences (after - before) with a percentile
bootstrap 95 % interval (fixed seed, 10,000 resamples), max CPU seconds, and how many
paired solved runs got a costlier / cheaper and a longer / shorter plan. Prints a Markdown
table and writes the rows as JSON.

    .venv/bin/python bench/planner_compare.py BEFORE.json AFTER.json [--out rows.json]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.learning.metrics import wilson_interval

BOOTSTRAP_RESAMPLES = 10_000
BOOTSTRAP_SEED = 0
Key = tuple[str, str, str]


def bootstrap_median(differences: list[float]) -> tuple[float, float]:
    """Percentile bootstrap 95 % interval of the median of ``differences``."""
    if not differences:
        return math.nan, math.nan
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    values = np.asarray(differences, dtype=float)
    samples = rng.choice(values, size=(BOOTSTRAP_RESAMPLES, len(values)), replace=True)
    medians = np.median(samples, axis=1)
    return float(np.percentile(medians, 2.5)), float(np.percentile(medians, 97.5))


def load_runs(path: Path) -> dict[Key, dict[int, dict[str, Any]]]:
    """(example, algorithm, history) -> seed -> run, from a bench/planner.py JSON file."""
    try:
        data = json.loads(path.read_text())
        runs = data["runs"]
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise SystemExit(f"error: {path}: not a bench/planner.py result ({error})") from None
    grouped: dict[Key, dict[int, dict[str, Any]]] = {}
    for run in runs:
        # bench/planner_hidden.py names the problem (and its mode) instead
        example = run["example"] if "example" in run else run["problem"]
        key = (example, run["algorithm"], run.get("history", run.get("mode", "cold")))
        grouped.setdefault(key, {})[int(run["seed"])] = run
    return grouped


def compare(before: dict[Key, dict[int, dict[str, Any]]],
            after: dict[Key, dict[int, dict[str, Any]]]) -> list[dict[str, Any]]:
    """One row per key present in both files (see the module docstring)."""
    rows = []
    for key in sorted(before.keys() & after.keys()):
        old, new = before[key], after[key]
        seeds = sorted(old.keys() & new.keys())
        solved_old = sum(old[s]["status"] == "solved" for s in seeds)
        solved_new = sum(new[s]["status"] == "solved" for s in seeds)
        differences = [new[s]["cpu_s"] - old[s]["cpu_s"] for s in seeds]
        both = [s for s in seeds if old[s]["status"] == new[s]["status"] == "solved"]
        tolerance = 1e-9
        costlier = sum(new[s]["cost"] > old[s]["cost"] + tolerance for s in both)
        cheaper = sum(new[s]["cost"] < old[s]["cost"] - tolerance for s in both)
        longer = sum((new[s].get("length") or 0) > (old[s].get("length") or 0) for s in both)
        shorter = sum((new[s].get("length") or 0) < (old[s].get("length") or 0) for s in both)
        low, high = wilson_interval(solved_new, len(seeds))
        ci = bootstrap_median(differences)
        rows.append({
            "example": key[0], "algorithm": key[1], "history": key[2], "seeds": len(seeds),
            "solved_before": solved_old, "solved_after": solved_new,
            "wilson95_after": [low, high],
            "median_cpu_before": statistics.median(old[s]["cpu_s"] for s in seeds),
            "median_cpu_after": statistics.median(new[s]["cpu_s"] for s in seeds),
            "paired_median_diff": statistics.median(differences) if differences else math.nan,
            "paired_median_diff_ci95": list(ci),
            "max_cpu_before": max(old[s]["cpu_s"] for s in seeds),
            "max_cpu_after": max(new[s]["cpu_s"] for s in seeds),
            "costlier": costlier, "cheaper": cheaper, "longer": longer, "shorter": shorter,
            "timeouts_after": sum(new[s]["status"] == "timeout" for s in seeds)})
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """The rows as a Markdown table."""
    lines = ["| example | algorithm | solved before / after (Wilson 95 % after) | median CPU s "
             "before | after | paired median diff (95 % CI) | max CPU s before / after | "
             "costlier / cheaper | longer / shorter |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        low, high = r["wilson95_after"]
        ci_low, ci_high = r["paired_median_diff_ci95"]
        lines.append(
            f"| {r['example']} | {r['algorithm']} | {r['solved_before']}/{r['seeds']} / "
            f"{r['solved_after']}/{r['seeds']} ({low:.2f}-{high:.2f}) | "
            f"{r['median_cpu_before']:.3f} | {r['median_cpu_after']:.3f} | "
            f"{r['paired_median_diff']:+.3f} ({ci_low:+.3f}..{ci_high:+.3f}) | "
            f"{r['max_cpu_before']:.3f} / {r['max_cpu_after']:.3f} | "
            f"{r['costlier']} / {r['cheaper']} | {r['longer']} / {r['shorter']} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)
    try:
        rows = compare(load_runs(args.before), load_runs(args.after))
    except SystemExit as error:
        print(error, file=sys.stderr)
        return 2
    print(table(rows))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
