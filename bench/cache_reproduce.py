"""Do cached fidelity trials reproduce exactly with the code as it is now?

After a change to an engine's settings that should leave some skills' trials untouched (issue
#20: the PyBullet push world got its own 2 cm contact breaking threshold, the bead worlds keep
4 mm), this re-runs the first ``--n`` cached records (lowest trial seeds) of ``--setting`` and
``--skill`` from a :mod:`bench.fidelity` cache, with the same inputs and seeds, and compares
score and validity exactly (bit for bit: ``==`` on the floats). The cache is only read.

A record's key must carry the setting's *current* physics version
(:func:`bench.fidelity.trial_key`): a reproduced record is then one a rerun of the row would
reuse. The table gives the count that reproduce, the largest score difference and the CPU
seconds per trial; the summary (with every record's old and new score) is written to
``--out``. ``--interleave push`` runs one trial of that skill (a fixed valid input) on the same
backend before every rerun, so another skill's world (the push's 2 cm) has stepped last in the
process each time: Bullet's contact breaking threshold is process-global, and the reruns show
that it does not leak. The committed run (loaded 2-core machine, about 2 CPU-minutes for both):

    OMP_NUM_THREADS=1 .venv/bin/python bench/cache_reproduce.py --skill pour --skill scoop \
        --n 20 --interleave push --cache docs/results/fidelity/engine_trials_v2.jsonl \
        --out docs/results/fidelity/bead_worlds_reproduce.json
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

from bench.fidelity import SETTINGS, draw_inputs, load_cache, run_trial, trial_key
from ltamp_cli.backends import SkillBackend


def cached_records(cache: dict[str, dict], setting: str, skill: str, n: int) -> list[dict]:
    """The first ``n`` records (by trial seed) of ``setting`` and ``skill`` whose keys match
    the current physics version; raises ``ValueError`` when there are fewer than ``n``."""
    chosen = []
    for record in cache.values():
        if record.get("setting") != setting or record.get("skill") != skill:
            continue
        key = trial_key(setting, skill, np.asarray(record["context"]),
                        np.asarray(record["control"]), int(record["seed"]))
        if key == record["key"]:
            chosen.append(record)
    chosen.sort(key=lambda record: int(record["seed"]))
    if len(chosen) < n:
        raise ValueError(f"the cache has {len(chosen)} {setting} {skill} records of the "
                         f"current physics version, fewer than {n}")
    return chosen[:n]


def interleaved_input(backend: SkillBackend, skill: str) -> tuple[np.ndarray, np.ndarray]:
    """A fixed valid input (context, control) of ``skill`` (seed 0's first valid draw)."""
    inputs = draw_inputs(backend, backend, skill, 1, 0)
    return inputs[0]


def reproduce(records: list[dict], setting: str, skill: str, progress: bool,
              interleave: str | None = None) -> dict:
    """Re-run ``records`` with ``setting``'s backend; exact comparison per record. With
    ``interleave``, one trial of that skill runs on the same backend before each rerun."""
    backend = SETTINGS[setting]()
    rows = []
    start = time.process_time()
    try:
        other = None if interleave is None else interleaved_input(backend, interleave)
        for index, record in enumerate(records):
            if interleave is not None and other is not None:
                backend.run_trial(interleave, other[0], other[1], 0)
            new = run_trial(backend, setting, skill, np.asarray(record["context"]),
                            np.asarray(record["control"]), int(record["seed"]))
            same = new["score"] == record["score"] and new["valid"] == record["valid"]
            rows.append({"seed": int(record["seed"]), "score_cached": record["score"],
                         "score_now": new["score"], "valid_cached": record["valid"],
                         "valid_now": new["valid"], "identical": bool(same)})
            if progress:
                print(f"\r{skill}: {index + 1}/{len(records)}", end="", file=sys.stderr,
                      flush=True)
    finally:
        backend.close()
        if progress:
            print(file=sys.stderr)
    cpu = time.process_time() - start
    diffs = [abs(r["score_now"] - r["score_cached"]) for r in rows
             if r["score_now"] is not None and r["score_cached"] is not None]
    return {"setting": setting, "skill": skill, "n": len(rows),
            "identical": sum(r["identical"] for r in rows),
            "max_abs_score_difference": max(diffs, default=0.0),
            "interleaved_skill": interleave,
            "cpu_s_per_trial_with_interleaved": cpu / max(1, len(rows)), "records": rows}


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cache", type=Path, required=True, help="a bench/fidelity.py cache")
    parser.add_argument("--setting", default="pybullet", help="setting whose trials to rerun")
    parser.add_argument("--skill", action="append", required=True, help="repeatable")
    parser.add_argument("--n", type=int, default=20, help="records per skill")
    parser.add_argument("--interleave", default=None, metavar="SKILL",
                        help="run one trial of SKILL before each rerun (e.g. push)")
    parser.add_argument("--out", type=Path, required=True, help="JSON summary")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")
    args = parser.parse_args(argv)
    if args.n < 1:
        parser.error("--n must be at least 1")
    if args.setting not in SETTINGS:
        parser.error(f"--setting must be one of {', '.join(SETTINGS)}")
    if args.interleave is not None and args.interleave not in ("pour", "scoop", "push", "stir"):
        parser.error("--interleave must be a Kitchen3D skill: pour, scoop, push or stir")
    if not args.cache.is_file():
        parser.error(f"--cache {args.cache} is not a file")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    cache = load_cache(args.cache)
    try:
        chosen = {skill: cached_records(cache, args.setting, skill, args.n)
                  for skill in dict.fromkeys(args.skill)}
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    results = [reproduce(records, args.setting, skill, not args.quiet, args.interleave)
               for skill, records in chosen.items()]
    # CPU s/trial includes the interleaved trial when there is one.
    print(f"{'setting':<10} {'skill':<6} {'identical':>10} {'max |dscore|':>13} "
          f"{'CPU s/trial':>12}")
    for r in results:
        print(f"{r['setting']:<10} {r['skill']:<6} {r['identical']:>4}/{r['n']:<5} "
              f"{r['max_abs_score_difference']:>13.3g} "
              f"{r['cpu_s_per_trial_with_interleaved']:>12.2f}")
    summary = {"cache": str(args.cache), "machine": platform.platform(), "results": results}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(summary, indent=1))
    print(f"wrote {args.out}")
    return 0 if all(r["identical"] == r["n"] for r in results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
