"""PDDLStream itself beside ltamp on PDDLStream's own examples (same files, same samplers).

Each example command line runs ``--seeds`` times under PDDLStream (its ``solve`` with the
algorithm the example's flags choose, in a Python environment where PDDLStream and its Fast
Downward work) and under ltamp (``bench/pddlstream_examples.py``: the same script with its
``pddlstream`` imports redirected to :mod:`ltamp_cli.pddlstream`, solved by ``adaptive``).
Runs alternate between the two planners so that machine load hits both alike. Each run is a
subprocess; the table gives solved runs, the median solve time each planner reports (wall
seconds inside ``solve``) and the median CPU seconds of the whole process (interpreter and
imports included), and writes JSON.

PDDLStream needs Fast Downward under ``<checkout>/downward/builds/release/bin`` (its
``translate`` folder from the ``caelan/downward`` commit the checkout pins, and a ``downward``
search binary, e.g. the one inside the ``up-fast-downward`` wheel; with a newer binary drop
the ``transform=...`` options from ``pddlstream/algorithms/downward.py``). Without a working
checkout it prints why and exits 0: this is a side-by-side benchmark, never part of CI.

    .venv/bin/python bench/pddlstream_side_by_side.py /tmp/pds --pddlstream-python \\
        /tmp/pdsvenv/bin/python --seeds 5 \\
        --runs "continuous_tamp.run:-a adaptive -n 2" "continuous_tamp.run:-a adaptive -n 8"
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
DEFAULT_OUT = REPO / "bench" / "results" / "pddlstream_side_by_side.json"
DEFAULT_RUNS = (
    "continuous_tamp.run:-a adaptive -n 2",
    "continuous_tamp.run:-a adaptive -n 4",
    "continuous_tamp.run:-a adaptive -n 8",
    "continuous_tamp.run:-a adaptive -p blocked -n 4",
    "kitchen.run:",
    "continuous_tamp.idtmp.run:",
)
SUMMARY = re.compile(r"Summary: \{(.*)\}")


def _run(command: list[str], cwd: Path, timeout: float) -> tuple[str, float, bool]:
    """(stdout, CPU seconds of the process tree, finished in time)."""
    before = os.times()
    try:
        done = subprocess.run(command, cwd=cwd, capture_output=True, text=True,
                              timeout=timeout, env={**os.environ, "OMP_NUM_THREADS": "1",
                                                    "MPLBACKEND": "Agg", "DISPLAY": ""})
        output, finished = done.stdout, True
    except subprocess.TimeoutExpired as expired:
        output = expired.stdout.decode() if isinstance(expired.stdout, bytes) else ""
        finished = False
    after = os.times()
    cpu = (after.children_user - before.children_user) + (after.children_system
                                                           - before.children_system)
    return output, cpu, finished


def run_pddlstream(python: str, checkout: Path, module: str, args: list[str],
                   timeout: float) -> dict[str, Any]:
    output, cpu, finished = _run([python, "-m", f"examples.{module}", *args], checkout,
                                 timeout)
    match = SUMMARY.search(output)
    fields = dict(re.findall(r"(\w+): ([^,]+)", match.group(1))) if match else {}
    solved = fields.get("solved") == "True"
    return {"solved": solved, "solve_s": float(fields.get("run_time", "nan")),
            "cost": float(fields.get("cost", "inf")), "cpu_s": cpu, "finished": finished}


def run_ltamp(checkout: Path, module: str, args: list[str], max_time: float,
              timeout: float) -> dict[str, Any]:
    example = module.replace(".", "/") + ".py"
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "row.json"
        _, cpu, finished = _run([sys.executable, str(REPO / "bench" / "pddlstream_examples.py"),
                                 str(checkout), "--only", example, "--max-time", str(max_time),
                                 "--example-args", " ".join(args), "--out", str(out)],
                                REPO, timeout)
        rows = json.loads(out.read_text())["examples"] if out.exists() else []
    row = rows[0] if rows else {}
    return {"solved": bool(row.get("solved")), "solve_s": row.get("solve_s", float("nan")),
            "cost": row.get("cost") or float("inf"), "cpu_s": cpu, "finished": finished}


def _median(values: list[float]) -> float:
    return statistics.median(values) if values else float("nan")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkout", type=Path)
    parser.add_argument("--pddlstream-python", default=sys.executable,
                        help="a Python that can import the checkout's pddlstream")
    parser.add_argument("--runs", nargs="+", default=list(DEFAULT_RUNS),
                        help="MODULE:ARGS, the example module under examples/ and its flags")
    parser.add_argument("--seeds", type=int, default=5, help="runs per planner and example")
    parser.add_argument("--max-time", type=float, default=60.0)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args()
    checkout = args.checkout.resolve()
    if not (checkout / "downward" / "builds" / "release" / "bin").is_dir():
        print(f"no PDDLStream checkout with a Fast Downward build at {checkout}: skipped")
        return 0
    timeout = args.max_time + 60
    rows = []
    print(f"{'example':<50} {'planner':<10} {'solved':>7} {'solve s':>8} {'CPU s':>7}")
    for spec in args.runs:
        module, _, flags = spec.partition(":")
        runs: dict[str, list[dict[str, Any]]] = {"pddlstream": [], "ltamp": []}
        for _ in range(args.seeds):
            runs["pddlstream"].append(run_pddlstream(args.pddlstream_python, checkout, module,
                                                     flags.split(), timeout))
            runs["ltamp"].append(run_ltamp(checkout, module, flags.split(), args.max_time,
                                           timeout))
        for planner, results in runs.items():
            solved = [r for r in results if r["solved"]]
            row = {"example": spec, "planner": planner, "runs": results,
                   "solved": len(solved), "n": len(results),
                   "median_solve_s": _median([r["solve_s"] for r in solved]),
                   "median_cpu_s": _median([r["cpu_s"] for r in results])}
            rows.append(row)
            print(f"{spec:<50} {planner:<10} {len(solved):>3}/{len(results):<3} "
                  f"{row['median_solve_s']:>8.3f} {row['median_cpu_s']:>7.2f}", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"checkout": str(checkout), "seeds": args.seeds,
                                    "max_time": args.max_time, "finished": time.time(),
                                    "rows": rows}, indent=2))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
