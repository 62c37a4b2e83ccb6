"""``python -m bench.paper --quick|--full|--smoke [--out DIR] [--only NAME,...]``.

Regenerates the seed paper's experiments (one module each, listed in :data:`EXPERIMENTS`) into
``--out`` (JSON + PNG; regenerable trial pools under ``--out/cache``), then writes the report
(``docs/RESULTS.md`` for quick/full, ``<out>/RESULTS.md`` for smoke unless ``--report`` says
otherwise). ``--jobs 2`` runs two experiments at a time in separate processes. An experiment
that fails is recorded as failed in its JSON (with the error line) and the others still run.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import resource
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

from bench.paper.common import REPO, Context  # noqa: E402

# name -> module; the order is the report's (and the paper's) order.
EXPERIMENTS = {
    "al2d": "bench.paper.al2d",
    "supervised3d": "bench.paper.supervised3d",
    "active3d": "bench.paper.active3d",
    "sampling": "bench.paper.sampling_table",
    "kernel_learning": "bench.paper.kernel_learning",
    "confident": "bench.paper.confident",
    "coffee": "bench.paper.coffee",
}
# Experiments that need no trial pool start at once, longest first (quick, last runs: sampling
# ~550 s CPU, al2d ~160, kernel_learning ~80, coffee ~30): with two at a time the two lanes
# then end closer together than cheapest-first, where sampling started last and ran alone.
# The pool experiments start when the pools are collected.
UNPOOLED_ORDER = ["sampling", "al2d", "kernel_learning", "coffee"]
POOLED_ORDER = ["confident", "supervised3d", "active3d"]


def run_one(name: str, ctx: Context) -> tuple[str, float, float, str]:
    """Run one experiment; returns ``(name, wall s, CPU s of this process, error or "")``."""
    import torch

    torch.set_num_threads(1)
    started, cpu = time.perf_counter(), time.process_time()
    try:
        importlib.import_module(EXPERIMENTS[name]).run(ctx)
        return name, time.perf_counter() - started, time.process_time() - cpu, ""
    except Exception as error:
        traceback.print_exc()
        message = f"{type(error).__name__}: {error}".splitlines()[0][:300]
        (ctx.out / f"{name}.json").write_text(json.dumps(
            {"experiment": name, "mode": ctx.mode, "failed": True, "error": message}, indent=2))
        return name, time.perf_counter() - started, time.process_time() - cpu, message


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.paper", description=__doc__)
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--quick", action="store_const", dest="mode", const="quick")
    mode.add_argument("--full", action="store_const", dest="mode", const="full")
    mode.add_argument("--smoke", action="store_const", dest="mode", const="smoke")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results" / "paper")
    parser.add_argument("--only", default="", help="comma-separated experiment names")
    parser.add_argument("--jobs", type=int, default=2, help="experiments run at once")
    parser.add_argument("--workers", type=int, default=2, help="trial-collection workers")
    parser.add_argument("--report", type=Path, default=None,
                        help="Markdown report path (default: docs/RESULTS.md; smoke: OUT)")
    parser.add_argument("--no-report", action="store_true")
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.only.split(",") if n.strip()] or list(EXPERIMENTS)
    unknown = [n for n in names if n not in EXPERIMENTS]
    if unknown:
        print(f"--only: unknown experiment {unknown[0]!r}: expected one of "
              f"{', '.join(EXPERIMENTS)}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    ctx = Context(args.mode, args.out.resolve(), sys.stderr.isatty(), args.workers)
    started = time.perf_counter()
    unpooled = [n for n in UNPOOLED_ORDER if n in names]
    pooled = [n for n in POOLED_ORDER if n in names]
    results: list[tuple[str, float, float, str]] = []

    def report_done(result: tuple[str, float, float, str]) -> None:
        results.append(result)
        name, seconds, _, error = result
        print(f"[{time.perf_counter() - started:7.1f} s] {name}: "
              f"{'FAILED ' + error if error else f'done in {seconds:.1f} s'}", flush=True)

    def collect_pools() -> None:
        from bench.paper.pools import prepare_pools

        t0 = time.perf_counter()
        prepare_pools(ctx, [ctx.sizes(importlib.import_module(EXPERIMENTS[n]).SIZES)
                            for n in pooled])
        print(f"[{time.perf_counter() - started:7.1f} s] trial pools ready "
              f"({time.perf_counter() - t0:.1f} s)", flush=True)

    if args.jobs <= 1:
        for name in unpooled:
            report_done(run_one(name, ctx))
        if pooled:
            collect_pools()
        for name in pooled:
            report_done(run_one(name, ctx))
    else:
        with ProcessPoolExecutor(max_workers=args.jobs) as executor:
            futures = [executor.submit(run_one, name, ctx) for name in unpooled]
            if pooled:
                # Collected here while the workers run the other experiments: the pools are
                # complete before any experiment reads them, and only one process writes them.
                collect_pools()
            futures += [executor.submit(run_one, name, ctx) for name in pooled]
            for future in as_completed(futures):
                report_done(future.result())
    total = time.perf_counter() - started
    # CPU of this process and of every finished child (experiment and collection workers):
    # what the run would cost on dedicated cores, whatever else shares the machine.
    usage = [resource.getrusage(who) for who in (resource.RUSAGE_SELF,
                                                 resource.RUSAGE_CHILDREN)]
    total_cpu = sum(u.ru_utime + u.ru_stime for u in usage)
    record = {"mode": args.mode, "total_wall_s": round(total, 1),
              "total_cpu_s": round(total_cpu, 1), "jobs": args.jobs,
              "experiments": {n: {"wall_s": round(s, 1), "cpu_s": round(c, 1), "error": e}
                              for n, s, c, e in results}}
    # An --only rerun into the same folder updates the record of the earlier run(s).
    previous = ctx.out / "run.json"
    if previous.is_file() and args.only:
        earlier = json.loads(previous.read_text())
        if earlier.get("mode") == args.mode:
            record["invocations"] = earlier.get("invocations", 1) + 1
            for key in ("total_wall_s", "total_cpu_s"):
                record[key] = round(record[key] + earlier.get(key, 0.0), 1)
            record["experiments"] = {**earlier.get("experiments", {}), **record["experiments"]}
    previous.write_text(json.dumps(record, indent=2))
    print(f"{args.mode}: {len(results)} experiment(s) in {total:.1f} s wall, "
          f"{total_cpu:.1f} s CPU", flush=True)
    if not args.no_report:
        from bench.paper.report import write_report

        report = args.report or (args.out / "RESULTS.md" if args.mode == "smoke"
                                 else REPO / "docs" / "RESULTS.md")
        write_report(ctx.out, report)
        print(f"wrote {report}")
    return 1 if any(e for *_, e in results) else 0


if __name__ == "__main__":
    sys.exit(main())
