"""``python -m bench.paper --quick|--standard|--full|--smoke [--out DIR] [--only NAME,...]``.

Regenerates the seed paper's experiments (one module each, listed in :data:`EXPERIMENTS`) into
``--out`` (JSON + PNG; regenerable trial pools under ``--out/cache``), then writes the report
(``docs/RESULTS.md`` for quick/standard/full, ``<out>/RESULTS.md`` for smoke unless
``--report`` says otherwise). Every experiment logs each finished job (learner × seed, say)
under ``<out>/runs/`` (committed, like the trial-pool archives in ``<out>/pools/``), so
rerunning the same command after an interruption continues where it stopped, and the full run
can be done in several pieces. ``--jobs 2`` keeps two processes busy: the work is cut into
units (trial-pool
collections, experiments, and the independent parts of a split experiment such as the
sampling table's rows) started critical-path first (``bench.paper.schedule``), one per
process. An experiment that fails is recorded as failed in its JSON (with the error line) and
the others still run.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import json
import os
import resource
import subprocess
import sys
import time
import traceback
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

from bench.paper.common import REPO, Context  # noqa: E402
from bench.paper.pools import skill_backend  # noqa: E402
from bench.paper.schedule import Unit, pick, ranks, ready_units, simulate  # noqa: E402

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
#: Experiments that read the Kitchen3D trial pools (collected first, see ``pool_units``).
POOLED = ("confident", "supervised3d", "active3d")
#: Estimated CPU seconds per experiment (quick runs, 2 cores shared with other jobs; coffee
#: measured 12 and 121 s in two runs): they only order the work (``bench.paper.schedule``).
#: Split experiments estimate their parts.
ESTIMATED_CPU_S = {"supervised3d": 140.0, "active3d": 150.0,
                   "kernel_learning": 60.0, "confident": 100.0, "coffee": 60.0}
#: Estimated CPU seconds per collected pool trial (valid-only: redrawn until the pre-check
#: passes; a quick run's 100 + 100 trials cost ~650 s CPU, ~30 % of it pour; SAPIEN: the
#: fidelity engine rows' 0.21 s per pour trial plus its pre-check redraws, and 0.81 s per
#: scoop trial on the bead bed before c6ce341, ~1.2x that on today's bed).
POOL_TRIAL_CPU_S = {("pybullet", "pour"): 2.0, ("pybullet", "scoop"): 4.6,
                    ("sapien", "pour"): 0.3, ("sapien", "scoop"): 1.1}


def pool_units(ctx: Context, pooled: list[str]) -> list[Unit]:
    """One collection unit per pool file the pooled experiments need (the largest size)."""
    wanted: dict[tuple[str, str], int] = {}
    for name in pooled:
        entry = ctx.sizes(importlib.import_module(EXPERIMENTS[name]).SIZES)
        for skill in entry["skills"]:
            key = (skill_backend(entry, str(skill)), str(skill))
            wanted[key] = max(wanted.get(key, 0), int(entry["n_train"]) + int(entry["n_test"]))
    return [Unit(f"pool:{backend}_{skill}", None, f"{backend}:{skill}:{n}",
                 n * POOL_TRIAL_CPU_S.get((backend, skill), 0.05))
            for (backend, skill), n in wanted.items()]


def _pool_skill(unit: Unit) -> str:
    """The skill of a pool unit (its part is ``backend:skill:n``)."""
    return str(unit.part).split(":")[1]


def plan(ctx: Context, names: list[str], pools_only: bool = False) -> list[Unit]:
    """The units of work for the experiments ``names``: pools, parts and whole experiments
    (``pools_only``: only the trial-pool collections the pooled ones among them need)."""
    pooled = [n for n in names if n in POOLED]
    pools = pool_units(ctx, pooled) if pooled else []
    units = list(pools)
    if pools_only:
        return units
    for name in names:
        module = importlib.import_module(EXPERIMENTS[name])
        after = tuple(p.key for p in pools) if name in POOLED else ()
        if hasattr(module, "parts"):
            # A pooled experiment's parts are its skills: each waits only for its own pool.
            units += [Unit(f"{name}:{part}", name, part, cost,
                           tuple(p.key for p in pools if _pool_skill(p) == part)
                           if name in POOLED else after)
                      for part, cost in module.parts(ctx)]
        else:
            units.append(Unit(name, name, None, ESTIMATED_CPU_S.get(name, 60.0), after))
    return units


Result = tuple[str, float, float, str]  # (unit key, wall s, CPU s of its process, error)


def run_unit(unit: Unit, ctx: Context, collection_workers: int) -> Result:
    """Run one unit in this process; an error is returned (its traceback printed), not
    raised. A failed whole experiment still gets its JSON, marked failed."""
    import torch

    torch.set_num_threads(1)
    started, cpu = time.perf_counter(), time.process_time()
    try:
        if unit.experiment is None:
            from bench.paper.pools import get_pool

            backend, skill, n = str(unit.part).split(":")
            get_pool(dataclasses.replace(ctx, workers=collection_workers), backend, skill,
                     int(n), 0)
        elif unit.part is None:
            importlib.import_module(EXPERIMENTS[unit.experiment]).run(ctx)
        else:
            importlib.import_module(EXPERIMENTS[unit.experiment]).run_part(ctx, unit.part)
        return unit.key, time.perf_counter() - started, time.process_time() - cpu, ""
    except Exception as error:
        traceback.print_exc()
        message = f"{type(error).__name__}: {error}".splitlines()[0][:300]
        if unit.experiment is not None and unit.part is None:
            _write_failed(ctx, unit.experiment, message)
        return unit.key, time.perf_counter() - started, time.process_time() - cpu, message


def _write_failed(ctx: Context, name: str, message: str) -> None:
    (ctx.out / f"{name}.json").write_text(json.dumps(
        {"experiment": name, "mode": ctx.mode, "failed": True, "error": message}, indent=2))


def run_units(units: list[Unit], ctx: Context, jobs: int, collection_workers: int,
              on_done: Callable[[Result], None], merge: bool = True) -> list[Result]:
    """Run ``units`` on ``jobs`` lanes (``<= 1``: in this process) in :func:`pick` order and
    merge each split experiment once all its parts are done (``merge=False``: never, for runs
    of some parts only). Returns a result per unit, plus one per split experiment's merge (key
    ``<name>:merge``).

    A failed pool fails the experiments waiting for it without running them (an experiment
    would otherwise collect the rest itself, and two of them could append to one file); a
    failed part fails its experiment (its JSON says which part and why).
    """
    rank = ranks(units)
    pending = list(units)
    finished: set[str] = set()
    failed: dict[str, str] = {}  # unit key -> error
    results: list[Result] = []
    left = {u.experiment: 0 for u in units
            if merge and u.part is not None and u.experiment}
    for unit in units:
        if unit.experiment in left:
            left[unit.experiment] += 1

    def finish(result: Result) -> None:
        key = result[0]
        unit = next(u for u in units if u.key == key)
        results.append(result)
        on_done(result)
        finished.add(key)
        if result[3]:
            failed[key] = result[3]
        name = unit.experiment
        if name in left:
            left[name] -= 1
            if left[name] == 0:
                results.append(merge_parts(name, units, failed, ctx))
                on_done(results[-1])

    def startable() -> Unit | None:
        """The next unit to start; units whose pools failed are finished as failed."""
        while True:
            ready = ready_units(pending, finished)
            if not ready:
                return None
            unit = pick(ready, rank)
            pending.remove(unit)
            broken = [k for k in unit.after if k in failed]
            if not broken:
                return unit
            message = f"not run: {broken[0]} failed ({failed[broken[0]]})"[:300]
            if unit.experiment is not None and unit.part is None:
                _write_failed(ctx, unit.experiment, message)
            finish((unit.key, 0.0, 0.0, message))

    if jobs <= 1:
        while (unit := startable()) is not None:
            finish(run_unit(unit, ctx, collection_workers))
        return results
    with ProcessPoolExecutor(max_workers=jobs) as executor:
        running: dict[Future[Result], Unit] = {}
        while True:
            while len(running) < jobs and (unit := startable()) is not None:
                running[executor.submit(run_unit, unit, ctx, collection_workers)] = unit
            if not running:
                break
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in done:
                running.pop(future)
                finish(future.result())
    return results


def merge_parts(name: str, units: list[Unit], failed: dict[str, str], ctx: Context) -> Result:
    """Join the parts of experiment ``name`` (in this process; cheap) or record its failure."""
    broken = [u.key for u in units if u.experiment == name and u.key in failed]
    started, cpu = time.perf_counter(), time.process_time()
    message = f"part {broken[0]} failed: {failed[broken[0]]}"[:300] if broken else ""
    if not message:
        try:
            importlib.import_module(EXPERIMENTS[name]).merge(ctx)
        except Exception as error:
            traceback.print_exc()
            message = f"{type(error).__name__}: {error}".splitlines()[0][:300]
    if message:
        _write_failed(ctx, name, message)
    return f"{name}:merge", time.perf_counter() - started, time.process_time() - cpu, message


def experiment_records(units: list[Unit], results: list[Result]) -> dict[str, dict[str, Any]]:
    """Per experiment: wall and CPU seconds summed over its units (a split experiment's parts
    ran on several lanes, so its wall time is the sum of theirs, not a span), and the first
    error. Pools are not experiments: they are listed under ``units`` only."""
    by_key = {r[0]: r for r in results}
    records: dict[str, dict[str, Any]] = {}
    for unit in units:
        if unit.experiment is None or unit.key not in by_key:
            continue
        _key, wall, cpu, error = by_key[unit.key]
        entry = records.setdefault(unit.experiment, {"wall_s": 0.0, "cpu_s": 0.0, "error": ""})
        entry["wall_s"] = round(entry["wall_s"] + wall, 1)
        entry["cpu_s"] = round(entry["cpu_s"] + cpu, 1)
        entry["error"] = entry["error"] or error
    for name, entry in records.items():
        merged = by_key.get(f"{name}:merge")
        if merged is not None:
            entry["wall_s"] = round(entry["wall_s"] + merged[1], 1)
            entry["cpu_s"] = round(entry["cpu_s"] + merged[2], 1)
            entry["error"] = merged[3] or entry["error"]
    return records


def merge_run_records(earlier: dict[str, Any], newer: dict[str, Any]) -> dict[str, Any]:
    """``run.json`` after an ``--only`` rerun into a folder whose run.json is ``earlier``.

    The result is ``newer`` (its commit, finish time and jobs) with: the earlier ``notes``
    kept (before any of ``newer``'s own); total, per-experiment and per-unit wall/CPU seconds
    *added* for entries present in both (the rerun is more work on top of the earlier, not
    a replacement: resumed jobs cost nothing again), entries present in one only copied;
    each entry's ``error`` the newest run's (a rerun that succeeds clears an earlier error);
    and ``invocations`` counting every run folded in (a record without it counts as one).
    Neither input is modified.
    """
    record = dict(newer)
    record["invocations"] = (int(earlier.get("invocations", 1))
                             + int(newer.get("invocations", 1)))
    for key in ("total_wall_s", "total_cpu_s"):
        record[key] = round(float(newer.get(key, 0.0)) + float(earlier.get(key, 0.0)), 1)
    for key in ("experiments", "units"):
        merged = {name: dict(entry) for name, entry in earlier.get(key, {}).items()}
        for name, entry in newer.get(key, {}).items():
            if name not in merged:
                merged[name] = dict(entry)
                continue
            before = merged[name]
            merged[name] = {**before, **entry,
                            "wall_s": round(float(before.get("wall_s", 0.0))
                                            + float(entry.get("wall_s", 0.0)), 1),
                            "cpu_s": round(float(before.get("cpu_s", 0.0))
                                           + float(entry.get("cpu_s", 0.0)), 1),
                            "error": entry.get("error", "")}
        record[key] = merged
    notes = list(earlier.get("notes", [])) + [n for n in newer.get("notes", [])
                                               if n not in earlier.get("notes", [])]
    if notes:
        record["notes"] = notes
    return record


def source_commit() -> str:
    """The checked-out commit (``+dirty`` with uncommitted changes), or ``unknown``."""
    try:
        commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short=12", "HEAD"],
                                capture_output=True, text=True, check=True,
                                timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain",
                                "--untracked-files=no"], capture_output=True, text=True,
                               check=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return commit + ("+dirty" if dirty else "")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.paper", description=__doc__)
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--quick", action="store_const", dest="mode", const="quick")
    mode.add_argument("--standard", action="store_const", dest="mode", const="standard",
                      help="statistically meaningful Kitchen2D sizes in <= 2 h on 2 cores")
    mode.add_argument("--full", action="store_const", dest="mode", const="full")
    mode.add_argument("--smoke", action="store_const", dest="mode", const="smoke")
    parser.add_argument("--out", type=Path, default=None,
                        help="results folder (default: docs/results/<mode>, committed with "
                             "docs/RESULTS.md so its figures show; smoke: "
                             "bench/results/paper-smoke)")
    parser.add_argument("--only", default="", help="comma-separated experiment names")
    parser.add_argument("--jobs", type=int, default=2, help="units of work (processes) run at once")
    parser.add_argument("--workers", type=int, default=2,
                        help="trial-collection workers with --jobs 1 (with more jobs a pool "
                             "is collected in its own job's process)")
    parser.add_argument("--report", type=Path, default=None,
                        help="Markdown report path (default: docs/RESULTS.md; smoke: OUT)")
    parser.add_argument("--no-report", action="store_true")
    parser.add_argument("--parts", default="",
                        help="comma-separated parts to run alone (e.g. supervised3d:pour), after "
                             "the pools they need; no merge, no run.json, no report: a later "
                             "run without --parts reads their logged jobs back")
    parser.add_argument("--pools-only", action="store_true",
                        help="only collect (or resume) the trial pools the pooled experiments "
                             f"({', '.join(POOLED)}) need, then stop (no run.json, no report)")
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.only.split(",") if n.strip()] or list(EXPERIMENTS)
    unknown = [n for n in names if n not in EXPERIMENTS]
    if unknown:
        print(f"--only: unknown experiment {unknown[0]!r}: expected one of "
              f"{', '.join(EXPERIMENTS)}", file=sys.stderr)
        return 2
    if args.out is None:
        args.out = (REPO / "bench" / "results" / "paper-smoke" if args.mode == "smoke"
                    else REPO / "docs" / "results" / args.mode)
    args.out.mkdir(parents=True, exist_ok=True)
    ctx = Context(args.mode, args.out.resolve(), sys.stderr.isatty(), args.workers)
    started = time.perf_counter()
    units = plan(ctx, names, args.pools_only)
    if args.pools_only and not units:
        print(f"--pools-only: none of {', '.join(names)} uses a trial pool (those that do: "
              f"{', '.join(POOLED)})", file=sys.stderr)
        return 2
    wanted_parts = [k.strip() for k in args.parts.split(",") if k.strip()]
    if wanted_parts:
        known = {u.key: u for u in units if u.part is not None and u.experiment is not None}
        missing = [k for k in wanted_parts if k not in known]
        if missing or args.pools_only:
            problem = ("cannot be combined with --pools-only" if args.pools_only
                       else f"unknown part {missing[0]!r}")
            print(f"--parts: {problem}; parts of {', '.join(names)}: "
                  f"{', '.join(known) or 'none'}", file=sys.stderr)
            return 2
        needed = {key for k in wanted_parts for key in known[k].after}
        units = [u for u in units if u.key in needed or u.key in wanted_parts]
    estimate, _lanes = simulate(units, max(1, args.jobs))
    print(f"[{0.0:7.1f} s] {len(units)} unit(s) on {max(1, args.jobs)} lane(s), estimated "
          f"{estimate:.0f} s on idle cores", flush=True)

    def report_done(result: Result) -> None:
        key, seconds, _, error = result
        print(f"[{time.perf_counter() - started:7.1f} s] {key}: "
              f"{'FAILED ' + error if error else f'done in {seconds:.1f} s'}", flush=True)

    # Collection runs in its lane's process when lanes run in parallel (one process per
    # core), with ``--workers`` processes only when nothing else runs beside it.
    if args.pools_only and args.jobs <= 1:
        # One after another, cheapest pool first: a finished pool is usable sooner.
        results = []
        for unit in sorted(units, key=lambda u: u.cost):
            results.append(run_unit(unit, ctx, args.workers))
            report_done(results[-1])
    else:
        results = run_units(units, ctx, args.jobs, args.workers if args.jobs <= 1 else 1,
                            report_done, merge=not wanted_parts)
    total = time.perf_counter() - started
    if args.pools_only or wanted_parts:
        failed = [r for r in results if r[3]]
        print(f"{args.mode}: {len(results)} {'unit' if wanted_parts else 'pool'}(s) in "
              f"{total:.1f} s wall, "
              f"{len(failed)} failed", flush=True)
        return 1 if failed else 0
    # CPU of this process and of every finished child (experiment and collection workers):
    # what the run would cost on dedicated cores, whatever else shares the machine.
    usage = [resource.getrusage(who) for who in (resource.RUSAGE_SELF,
                                                 resource.RUSAGE_CHILDREN)]
    total_cpu = sum(u.ru_utime + u.ru_stime for u in usage)
    record = {"mode": args.mode, "commit": source_commit(), "finished": time.strftime(
                  "%Y-%m-%d %H:%M UTC", time.gmtime()), "total_wall_s": round(total, 1),
              "total_cpu_s": round(total_cpu, 1), "jobs": args.jobs,
              "experiments": experiment_records(units, results),
              "units": {k: {"wall_s": round(s, 1), "cpu_s": round(c, 1), "error": e}
                        for k, s, c, e in results}}
    # An --only rerun into the same folder updates the record of the earlier run(s).
    previous = ctx.out / "run.json"
    if previous.is_file() and args.only:
        earlier = json.loads(previous.read_text())
        if earlier.get("mode") == args.mode:
            record = merge_run_records(earlier, record)
    previous.write_text(json.dumps(record, indent=2))
    print(f"{args.mode}: {len(record['experiments'])} experiment(s) in {total:.1f} s wall, "
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
