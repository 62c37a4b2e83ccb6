"""The 3D scoop's bead bed (issue #20): the reference's bed rule against the fixed count.

Since #20 a scoop trial's bowl holds the drawn 200-300 beads raised to a bed of at least
``MIN_BED_DEPTH_M`` and capped at 75 % of the bowl's height (``scoop_bead_count``, as the
reference fills its bowls). Three measurements on PyBullet, free-floating spoon (the shipped
models' trials), one JSON line per trial appended to ``--log`` as it finishes (a rerun skips
the trials already there):

* ``compare``: ``--contexts`` contexts drawn as ``ltamp evaluate`` draws them (the backend's
  context distribution, ``--seed``), in each the first pre-check-valid control of 1,000
  uniform ones (``ltamp evaluate``'s random baseline), run once with the old bed (the drawn
  count only) and once with the new one, same trial seed: success rates (Wilson 95 %), CPU
  seconds per trial, bead counts; ``--out`` gets the summary JSON. Where the rule leaves the
  count unchanged the new trial is the old one (same seed, same beads) and is copied.
* ``noise``: the first ``--controls`` of those controls, each with ``--seeds`` trial seeds on
  the new bed: how often one control's label flips between seeds.
* ``relabel``: a trials pool (``--pool``, a ``trials.jsonl``) under the new bed into
  ``--into``: a valid trial whose bead count the rule leaves unchanged is copied (same seed,
  same beads: the same simulation; ``--verify`` of them are re-run to check that), every other
  valid trial is re-run with its own seed; pre-check rejections are copied. ``--reverse``
  runs from the pool's end, for a second process writing another file (merge by ``index``).

    OMP_NUM_THREADS=1 .venv/bin/python bench/scoop_bed.py compare --contexts 40 \\
        --log docs/results/scoop3d/bed_compare_trials.jsonl \\
        --out docs/results/scoop3d/bed_compare.json
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.pybullet.backend import Kitchen3DBackend
from ltamp_cli.backends.skills3d.common import sample_beads
from ltamp_cli.backends.skills3d.scoop import (
    SCOOP_SPEC,
    ScoopContext,
    ScoopSettings,
    bed_depth_m,
    sample_scoop_latents,
)
from ltamp_cli.learning.metrics import wilson_interval
from ltamp_cli.threads import use_one_thread

#: The bed before #20's fix: the drawn 200-300 beads whatever the bowl (no depth floor; the
#: cap at the full cavity never binds for these counts).
OLD_BED = ScoopSettings(min_bed_depth_m=0.0, max_fill_fraction=1.0)
NEW_BED = ScoopSettings()
#: Bowls with a base at least this wide (m) are reported separately ("wide").
WIDE_BASE_M = 0.15


@dataclass(frozen=True)
class TrialCopy:
    """A logged trial's outcome, standing for a re-run of the same seed."""

    valid: bool
    score: float
    info: dict[str, Any]


def bead_count(settings: ScoopSettings, context: np.ndarray, seed: int) -> int:
    """The bead count a scoop trial of ``seed`` in ``context`` (4,) creates."""
    bowl = ScoopContext.from_array(context).bowl
    return sample_scoop_latents(np.random.default_rng(seed), settings, bowl).beads.count


def drawn_radius(seed: int) -> float:
    """The bead radius (m) a scoop trial of ``seed`` draws."""
    s = NEW_BED
    return sample_beads(np.random.default_rng(seed), s.bead_count_mean, 20.0, 200.0,
                        300.0).radius


def read_log(path: Path) -> list[dict[str, Any]]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.open() if line.strip()]


def timed_trial(backend: Kitchen3DBackend, context: np.ndarray, control: np.ndarray,
                seed: int) -> tuple[Any, float]:
    start = time.process_time()
    result = backend.run_trial("scoop", context, control, seed)
    return result, time.process_time() - start


def sample_cases(contexts: int, seed: int, backend: Kitchen3DBackend
                 ) -> list[tuple[np.ndarray, np.ndarray | None, int]]:
    """``ltamp evaluate``'s contexts, random baseline controls and trial seeds."""
    rng = np.random.default_rng(seed)
    baseline_rng = np.random.default_rng([seed, 1])
    cases = []
    for index in range(contexts):
        context = backend.sample_context("scoop", rng)
        candidates = SCOOP_SPEC.control.sample_uniform(baseline_rng, 1000)
        control = None
        for start in range(0, len(candidates), 25):  # the first valid one, checked in chunks
            chunk = candidates[start:start + 25]
            valid = np.flatnonzero(backend.is_valid("scoop", context, chunk))
            if len(valid):
                control = chunk[valid[0]]
                break
        cases.append((context, control, seed * 100_003 + index))
    return cases


def record(kind: str, index: int, setting: str, context: np.ndarray, control: np.ndarray,
           seed: int, result: Any, cpu: float, settings: ScoopSettings) -> dict[str, Any]:
    radius = drawn_radius(seed)
    count = bead_count(settings, context, seed)
    bowl = ScoopContext.from_array(context).bowl
    return {
        "kind": kind, "index": index, "setting": setting, "seed": seed,
        "context": [float(v) for v in context], "control": [float(v) for v in control],
        "valid": bool(result.valid), "score": float(result.score),
        "success": bool(result.valid and result.score > 0), "cpu_s": cpu,
        "beads": count, "bed_depth_est_m": bed_depth_m(bowl, count, radius),
        "info": {k: v for k, v in result.info.items() if isinstance(v, (int, float, str))},
    }


def summarise(rows: list[dict[str, Any]], label: str) -> dict[str, Any]:
    n = len(rows)
    wins = sum(r["success"] for r in rows)
    cpu = [r["cpu_s"] for r in rows]
    return {
        "label": label, "trials": n, "successes": wins,
        "rate": wins / n if n else None, "wilson95": list(wilson_interval(wins, n)),
        "cpu_s_median": float(np.median(cpu)) if cpu else None,
        "cpu_s_mean": float(np.mean(cpu)) if cpu else None,
        "beads_median": float(np.median([r["beads"] for r in rows])) if rows else None,
        "bed_depth_est_mm_min": 1000 * min((r["bed_depth_est_m"] for r in rows), default=0.0),
    }


def run_compare(args: argparse.Namespace) -> dict[str, Any]:
    backends = {"old": Kitchen3DBackend(scoop_settings=OLD_BED),
                "new": Kitchen3DBackend(scoop_settings=NEW_BED)}
    settings = {"old": OLD_BED, "new": NEW_BED}
    done = {(r["index"], r["setting"]) for r in read_log(args.log) if r["kind"] == "compare"}
    cases = sample_cases(args.contexts, args.seed, backends["new"])
    old_rows = {r["index"]: r for r in read_log(args.log)
                if r["kind"] == "compare" and r["setting"] == "old"}
    with args.log.open("a") as log:
        for index, (context, control, seed) in enumerate(cases):
            if control is None:
                continue
            same_beads = bead_count(OLD_BED, context, seed) == bead_count(NEW_BED, context, seed)
            for name in ("old", "new"):
                if (index, name) in done:
                    continue
                if name == "new" and same_beads and (index, "old") in done:
                    # Same seed, same beads: the same simulation (relabel's --verify checks
                    # it); the old trial's result and CPU stand for the new one.
                    row = dict(old_rows[index], setting="new", copied=True)
                else:
                    result, cpu = timed_trial(backends[name], context, control, seed)
                    row = record("compare", index, name, context, control, seed, result, cpu,
                                 settings[name])
                if name == "old":
                    old_rows[index] = row
                    done.add((index, "old"))
                log.write(json.dumps(row) + "\n")
                log.flush()
                print(f"{index:3d} {name} beads {row['beads']:3d} score {row['score']:+.2f} "
                      f"cpu {cpu:.1f}s", flush=True)
    rows = [r for r in read_log(args.log) if r["kind"] == "compare"]
    table = []
    for name in ("old", "new"):
        mine = [r for r in rows if r["setting"] == name]
        table.append(summarise(mine, name))
        table.append(summarise([r for r in mine if r["context"][2] >= WIDE_BASE_M],
                               f"{name}, base >= {WIDE_BASE_M} m"))
        table.append(summarise([r for r in mine if r["context"][2] < WIDE_BASE_M],
                               f"{name}, base < {WIDE_BASE_M} m"))
    pairs = {}
    for r in rows:
        pairs.setdefault(r["index"], {})[r["setting"]] = r["success"]
    both = [p for p in pairs.values() if len(p) == 2]
    return {"mode": "compare", "contexts": args.contexts, "seed": args.seed, "table": table,
            "label_changes": sum(p["old"] != p["new"] for p in both), "paired": len(both)}


def theta_star_cases(paths: list[Path]) -> list[tuple[np.ndarray, np.ndarray, int, dict]]:
    """θ*'s (context, control, trial seed, evaluated row) per context of ``ltamp evaluate``
    JSONL logs (``bench/kitchen3d_models.py --log`` / ``bench/evaluate_shard.py``, seed 0):
    rows come in (θ*, random) pairs per context; a row names its context by ``index`` (the
    shards) or, lacking it, by ``seed`` (``kitchen3d_models.py``); the trial seed of
    ``ltamp evaluate --seed 0`` is the context's index. A context logged twice keeps its
    first row."""
    cases: dict[int, tuple[np.ndarray, np.ndarray, int, dict]] = {}
    for path in paths:
        seen: set[int] = set()
        for row in read_log(path):
            index = int(row["index"] if "index" in row else row["seed"])
            kind = row.get("kind") or ("random" if index in seen else "theta_star")
            seen.add(index)
            if kind == "theta_star" and index not in cases:
                cases[index] = (np.asarray(row["context"]), np.asarray(row["control"]), index,
                                row)
    return [cases[i] for i in sorted(cases)]


def _flip_summary(by_control: dict[int, list[dict[str, Any]]], seeds: int) -> dict[str, Any]:
    """Per control its labels over ``seeds`` trial seeds: how many controls have both labels
    (Wilson 95 %), the chance two seeds of one control disagree (bootstrap over controls),
    and the mean per-control success rate (what one live trial per context measures on
    average; bootstrap over controls)."""
    full = {i: rows for i, rows in by_control.items() if len(rows) >= seeds}
    labels = {i: [r["success"] for r in rows[:seeds]] for i, rows in full.items()}
    mixed = sum(0 < sum(s) < len(s) for s in labels.values())
    rates = np.array([np.mean(s) for s in labels.values()]) if labels else np.zeros(0)
    # P(two different seeds of one control disagree) = 2 p (1 - p) n / (n - 1) per control.
    flips = np.array([2 * r * (1 - r) * seeds / (seeds - 1) for r in rates]) if seeds > 1 \
        else np.zeros(0)
    rng = np.random.default_rng(0)

    def boot(values: np.ndarray) -> list[float] | None:
        if values.size == 0:
            return None
        means = [float(np.mean(rng.choice(values, values.size))) for _ in range(4000)]
        return [float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))]

    first = [s[0] for s in labels.values()]
    return {
        "controls": len(full), "seeds": seeds,
        "successes_per_control": {str(i): int(sum(s)) for i, s in sorted(labels.items())},
        "scores_per_control": {str(i): [round(r["score"], 3) for r in full[i][:seeds]]
                               for i in sorted(full)},
        "mixed_controls": mixed, "mixed_wilson95": list(wilson_interval(mixed, len(full))),
        "pair_flip_rate": float(np.mean(flips)) if flips.size else None,
        "pair_flip_bootstrap95": boot(flips),
        "first_seed_successes": int(sum(first)),
        "first_seed_wilson95": list(wilson_interval(int(sum(first)), len(first))),
        "mean_success_rate": float(np.mean(rates)) if rates.size else None,
        "mean_success_rate_bootstrap95": boot(rates),
        "trials": int(sum(len(s) for s in labels.values())),
        "trial_successes": int(sum(sum(s) for s in labels.values())),
        "trial_wilson95": list(wilson_interval(int(sum(sum(s) for s in labels.values())),
                                 int(sum(len(s) for s in labels.values())))),
        "cpu_s_median": float(np.median([r["cpu_s"] for rows in full.values()
                                         for r in rows[:seeds] if not r.get("copied")]))
        if full else None,
    }


def run_noise(args: argparse.Namespace) -> dict[str, Any]:
    """Each control with ``--seeds`` trial seeds (``base + 7919 k``, k = 0 the evaluation's
    own seed). ``--theta-star``: the controls are θ* of ``ltamp evaluate``'s logs, whose
    k = 0 trial is copied from the log (same seed, same beads: the same simulation) instead
    of re-run; otherwise ``ltamp evaluate``'s random valid baseline controls."""
    backend = Kitchen3DBackend(scoop_settings=NEW_BED)
    kind = "noise_theta_star" if args.theta_star else "noise"
    done = {(r["index"], r["seed"]) for r in read_log(args.log) if r["kind"] == kind}
    if args.theta_star:
        cases = theta_star_cases(args.theta_star)
    else:
        cases = [(c, u, s, None) for c, u, s in sample_cases(args.contexts, args.seed, backend)
                 if u is not None]
    with args.log.open("a") as log:
        for position, (context, control, base_seed, logged) in enumerate(cases[: args.controls]):
            index = base_seed if args.theta_star else position
            for k in range(args.seeds):
                seed = base_seed + 7919 * k
                if (index, seed) in done:
                    continue
                if k == 0 and logged is not None:
                    result = TrialCopy(bool(logged["valid"]), float(logged["score"]), {})
                    cpu = float(logged.get("cpu_s", 0.0))
                else:
                    result, cpu = timed_trial(backend, context, control, seed)
                row = record(kind, index, "new", context, control, seed, result, cpu, NEW_BED)
                if k == 0 and logged is not None:
                    row["copied"] = True
                log.write(json.dumps(row) + "\n")
                log.flush()
                print(f"{kind} {index:3d} seed {k} score {row['score']:+.2f} cpu {cpu:.1f}s",
                      flush=True)
    rows = [r for r in read_log(args.log) if r["kind"] == kind]
    by_control: dict[int, list[dict[str, Any]]] = {}
    for r in sorted(rows, key=lambda r: (r["index"], (r["seed"] - r["index"]) // 7919
                                         if args.theta_star else r["seed"])):
        by_control.setdefault(r["index"], []).append(r)
    return {"mode": "noise", "controls_from": "theta_star" if args.theta_star else "random",
            "sources": [str(p) for p in args.theta_star or []],
            **_flip_summary(by_control, args.seeds)}


def run_relabel(args: argparse.Namespace) -> dict[str, Any]:
    backend = Kitchen3DBackend(scoop_settings=NEW_BED)
    pool = read_log(args.pool)
    done = {r["index"] for r in read_log(args.into)}
    verified = sum(1 for r in read_log(args.into) if r.get("info", {}).get("relabel") == "verified")
    counts = {"copied": 0, "rerun": 0, "verified": 0, "verify_mismatch": 0}
    with args.into.open("a") as out:
        for old in reversed(pool) if args.reverse else pool:
            if old["index"] in done:
                continue
            context = np.asarray(old["context"])
            new = dict(old)
            if not old["valid"] or "beads_total" not in old["info"]:
                counts["copied"] += 1
            else:
                changed = bead_count(NEW_BED, context, old["seed"]) != old["info"]["beads_total"]
                if changed or verified < args.verify:
                    result, cpu = timed_trial(backend, context, np.asarray(old["control"]),
                                              old["seed"])
                    info = dict(result.info)
                    info["strategy"] = old["info"].get("strategy")
                    info["cpu_s"] = cpu
                    if changed:
                        info["relabel"] = "rerun"
                        counts["rerun"] += 1
                    else:
                        verified += 1
                        same = (result.score == old["score"]
                                and info.get("beads_in_spoon_end")
                                == old["info"].get("beads_in_spoon_end"))
                        info["relabel"] = "verified" if same else "verify_mismatch"
                        counts["verified" if same else "verify_mismatch"] += 1
                    new.update(score=float(result.score), valid=bool(result.valid), info=info,
                               wall_time_s=cpu)
                    print(f"{old['index']:3d} {info['relabel']} {old['score']:+.2f} -> "
                          f"{result.score:+.2f} cpu {cpu:.1f}s", flush=True)
                else:
                    counts["copied"] += 1
            out.write(json.dumps(new, sort_keys=True) + "\n")
            out.flush()
    return {"mode": "relabel", "pool": str(args.pool), "into": str(args.into), **counts}


def print_table(summary: dict[str, Any]) -> None:
    if summary["mode"] != "compare":
        print(json.dumps(summary, indent=1))
        return
    print(f"{'bed':<22} {'n':>3} {'succ':>4} {'rate':>5} {'wilson95':>13} "
          f"{'cpu med':>7} {'cpu mean':>8} {'beads':>5} {'min depth':>9}")
    for row in summary["table"]:
        lo, hi = row["wilson95"]
        rate = "-" if row["rate"] is None else f"{row['rate']:.2f}"
        cpu_med = "-" if row["cpu_s_median"] is None else f"{row['cpu_s_median']:.2f}"
        cpu_mean = "-" if row["cpu_s_mean"] is None else f"{row['cpu_s_mean']:.2f}"
        beads = "-" if row["beads_median"] is None else f"{row['beads_median']:.0f}"
        print(f"{row['label']:<22} {row['trials']:>3} {row['successes']:>4} {rate:>5} "
              f"{lo:.2f}-{hi:.2f}".ljust(55) + f" {cpu_med:>7} {cpu_mean:>8} {beads:>5} "
              f"{row['bed_depth_est_mm_min']:>7.1f}mm")
    print(f"labels changed by the bed: {summary['label_changes']} of {summary['paired']}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=("compare", "noise", "relabel"))
    parser.add_argument("--contexts", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--controls", type=int, default=20)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--pool", type=Path)
    parser.add_argument("--into", type=Path)
    parser.add_argument("--verify", type=int, default=3)
    parser.add_argument("--reverse", action="store_true",
                        help="relabel from the pool's end (a second process; merge by index)")
    parser.add_argument("--theta-star", type=Path, nargs="+", default=None,
                        help="noise: θ* controls from these ltamp evaluate JSONL logs")
    parser.add_argument("--log", type=Path)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args(argv)
    if args.mode == "relabel" and (args.pool is None or args.into is None):
        print("error: relabel needs --pool and --into", file=sys.stderr)
        return 2
    if args.mode != "relabel" and args.log is None:
        print(f"error: {args.mode} needs --log", file=sys.stderr)
        return 2
    if args.mode == "relabel" and not args.pool.is_file():
        print(f"error: no pool at {args.pool}", file=sys.stderr)
        return 2
    use_one_thread()
    run = {"compare": run_compare, "noise": run_noise, "relabel": run_relabel}[args.mode]
    summary = run(args)
    summary["machine"] = {"python": platform.python_version(), "note": "loaded 2-core machine"}
    print_table(summary)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(summary, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
