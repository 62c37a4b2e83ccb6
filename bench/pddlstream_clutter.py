"""Calibration for issue #19's crowded problems: does PDDLStream itself (adaptive) solve
``hidden_clutter_10``, ``hidden_clutter_12`` and ``hidden_stack_4`` with the same naive
samplers (uniform placements ignorant of other blocks) that ltamp gets?

Each (problem, settings, seed) is one child process running
``bench/problems/hidden19/run_pddlstream.py`` in a scratch folder (PDDLStream writes
``temp/`` and ``statistics/`` into its working directory). ``settings``: ``example`` (the
settings of PDDLStream's ``examples/continuous_tamp/run.py``) or ``default`` (``solve``'s own
defaults, only ``algorithm="adaptive"`` named). CPU: the solve's own plus its Fast Downward
subprocesses'. Stream calls are counted by kind (``gen``, ``fn``, ``test``).

    python bench/pddlstream_clutter.py --pddlstream /tmp/pds [--seeds 5] [--max-time 60]
        [--settings example,default] [--problems hidden_clutter_10,...] [--out FILE.json]

``--pddlstream``: a checkout made by ``bench/problems/hidden19/pddlstream_setup.sh``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
from pathlib import Path
from typing import Any

from planner_hidden import pddlstream_child

PROBLEMS = ("hidden_clutter_10", "hidden_clutter_12", "hidden_stack_4")


def run_one(checkout: Path, name: str, settings: str, seed: int, max_time: float
            ) -> dict[str, Any]:
    """One PDDLStream solve; ``status`` is solved / timeout / infeasible / killed / error."""
    report, wall, status = pddlstream_child(checkout, name, seed, max_time, settings)
    return {"problem": name, "settings": settings, "seed": seed, "status": status,
            "wall_s": wall, "cpu_s": report.get("cpu_s", float("nan"))
            + (report.get("fd_cpu_s") or 0.0), "fd_cpu_s": report.get("fd_cpu_s"),
            "cost": report.get("cost"), "length": report.get("length"),
            "calls": report.get("calls"), "load": os.getloadavg()[0]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pddlstream", type=Path, required=True)
    parser.add_argument("--problems", default=",".join(PROBLEMS))
    parser.add_argument("--settings", default="example,default")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--max-time", type=float, default=60.0)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    if not (args.pddlstream / "downward" / "builds" / "release" / "bin").is_dir():
        print(f"{args.pddlstream}: no Fast Downward build (run pddlstream_setup.sh)",
              file=sys.stderr)
        raise SystemExit(2)
    rows: list[dict[str, Any]] = []
    print(f"{'problem':<20} {'settings':<8} {'seed':>4} {'status':<10} {'cpu s':>7} "
          f"{'wall s':>7} {'load':>5}  calls", flush=True)
    for name in args.problems.split(","):
        for settings in args.settings.split(","):
            for seed in range(args.seeds):
                row = run_one(args.pddlstream, name, settings, seed, args.max_time)
                rows.append(row)
                print(f"{name:<20} {settings:<8} {seed:>4} {row['status']:<10} "
                      f"{row['cpu_s']:>7.2f} {row['wall_s']:>7.1f} {row['load']:>5.1f}  "
                      f"{row['calls']}", flush=True)
                args.out.write_text(json.dumps({"max_time": args.max_time, "runs": rows},
                                               indent=1))
    for name in args.problems.split(","):
        for settings in args.settings.split(","):
            mine = [r for r in rows if r["problem"] == name and r["settings"] == settings]
            solved = sum(r["status"] == "solved" for r in mine)
            print(f"{name:<20} {settings:<8} solved {solved}/{len(mine)}, median CPU "
                  f"{statistics.median(r['cpu_s'] for r in mine):.2f} s")


if __name__ == "__main__":
    main()
