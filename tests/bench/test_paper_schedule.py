"""How ``python -m bench.paper`` cuts its work into units and orders them on its lanes
(``bench.paper.schedule`` and the runner in ``bench.paper.__main__``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.paper import sampling_table
from bench.paper.__main__ import plan, run_units
from bench.paper.common import Context, JobLog
from bench.paper.schedule import Unit, ranks, simulate


def test_longest_first_ends_the_lanes_together() -> None:
    # Listed cheapest first: in listing order the 300 s unit would start at 100 s and end at
    # 400 s; longest first it runs alone on one lane while the others share the other one.
    units = [Unit("a", "a", cost=100.0), Unit("b", "b", cost=100.0), Unit("c", "c", cost=300.0)]
    makespan, lanes = simulate(units, 2)
    assert makespan == pytest.approx(300.0)
    assert lanes[0] == ["c"] and sorted(lanes[1]) == ["a", "b"]


def test_a_pool_on_the_critical_path_starts_before_longer_independent_work() -> None:
    # The pool (100 s) gates a 300 s experiment: rank 400 beats the 250 s units. Longest
    # first by own cost would start both 250 s units, then pool + experiment: 650 s.
    units = [Unit("a", "a", cost=250.0), Unit("b", "b", cost=250.0),
             Unit("pool:x", None, "x", cost=100.0),
             Unit("exp", "exp", cost=300.0, after=("pool:x",))]
    assert ranks(units)["pool:x"] == pytest.approx(400.0)
    makespan, lanes = simulate(units, 2)
    assert makespan == pytest.approx(500.0)
    assert lanes[0][:2] == ["pool:x", "exp"]


def test_ranks_reject_unknown_dependencies_and_cycles() -> None:
    with pytest.raises(ValueError, match="unknown unit 'nope'"):
        ranks([Unit("a", "a", after=("nope",))])
    with pytest.raises(ValueError, match="cycle"):
        ranks([Unit("a", "a", after=("b",)), Unit("b", "b", after=("a",))])


def test_quick_plan_splits_sampling_by_row_and_gates_pool_experiments(tmp_path: Path) -> None:
    ctx = Context("quick", tmp_path, False)
    units = {u.key: u for u in plan(ctx, ["sampling", "confident", "al2d"])}
    rows = sampling_table.SIZES["quick"]["rows"]
    parts = [k for k in units if k.startswith("sampling:")]
    assert parts == [f"sampling:{t}-{b}-{s}" for t, b, s, _ in rows]
    assert all(units[k].experiment == "sampling" and units[k].cost > 0 for k in parts)
    pools = sorted(k for k in units if k.startswith("pool:"))
    assert pools == ["pool:pybullet_pour", "pool:pybullet_scoop"]
    assert sorted(units["confident"].after) == pools
    assert [k for k in units if k.startswith("al2d:")] == ["al2d:pour", "al2d:scoop", "al2d:push"]
    assert all(units[f"al2d:{skill}"].after == () for skill in ("pour", "scoop", "push"))
    assert units["pool:pybullet_scoop"].part == "pybullet:scoop:100"  # 70 train + 30 test
    # With its estimates, the plan keeps both lanes busy to the end: within 3 % of the
    # bound total / 2 (cheapest first, the 3D pour row starts last: 965 s for a bound of
    # 808 s).
    makespan, _ = simulate(list(units.values()), 2)
    assert makespan <= 1.03 * sum(u.cost for u in units.values()) / 2


def test_failed_pool_fails_its_experiments_without_running_them(tmp_path: Path) -> None:
    ctx = Context("smoke", tmp_path, False, 1)
    units = [Unit("pool:synthetic_nope", None, "synthetic:nope:5", 1.0),
             Unit("confident", "confident", None, 1.0, ("pool:synthetic_nope",))]
    done: list[str] = []
    results = {r[0]: r for r in run_units(units, ctx, 1, 1, lambda r: done.append(r[0]))}
    assert done == ["pool:synthetic_nope", "confident"]
    assert results["pool:synthetic_nope"][3]
    assert results["confident"][3].startswith("not run: pool:synthetic_nope failed")
    assert results["confident"][2] == 0.0  # no CPU: it never ran
    data = json.loads((tmp_path / "confident.json").read_text())
    assert data["failed"] and "pool:synthetic_nope" in data["error"]


def test_sampling_parts_merge_in_row_order_and_never_from_stale_files(tmp_path: Path) -> None:
    ctx = Context("smoke", tmp_path, False, 1)
    names = [name for name, _ in sampling_table.parts(ctx)]
    assert len(names) == 2
    # An earlier run with other sizes logged the first row: it must never be merged.
    JobLog(ctx, f"sampling-{names[0]}", {"rows": "other sizes"}).put(names[0],
                                                                     [{"table": "stale"}])
    # The first row's unit fails (it names no row of this mode): although an earlier run's
    # log for that row exists, the experiment is failed, not merged from it.
    units = [Unit(f"sampling:{names[1]}", "sampling", names[1], 2.0),
             Unit(f"sampling:{names[0]}", "sampling", "no-such-row", 1.0)]
    results = {r[0]: r for r in run_units(units, ctx, 1, 1, lambda r: None)}
    assert results[f"sampling:{names[0]}"][3].startswith("KeyError")
    assert results["sampling:merge"][3].startswith(f"part sampling:{names[0]} failed")
    assert json.loads((tmp_path / "sampling.json").read_text())["failed"]
    with pytest.raises(FileNotFoundError, match=names[0]):
        sampling_table.merge(ctx)
    # Parts run in any order; the merged table keeps the report's row order.
    sampling_table.run_part(ctx, names[0])
    merged = sampling_table.merge(ctx)
    assert [f"{t['table']}-{t['backend']}-{t['skill']}" for t in merged["tables"]] == names
    written = json.loads((tmp_path / "sampling.json").read_text())
    assert not written.get("failed") and written["tables"] == merged["tables"]
    assert all(1 <= t["metrics"][s]["n5"]["mean"] <= 100 for t in merged["tables"]
               for s in merged["samplers"])
    # A rerun of a measured part reads it back (resuming an interrupted run) instead of
    # measuring again.
    assert sampling_table.run_part(ctx, names[0]) == merged["tables"][0]


def test_full_pooled_experiments_split_by_skill_and_wait_only_for_their_own_pool(
        tmp_path: Path) -> None:
    # The full pour pool (SAPIEN) can be complete while the scoop pool (PyBullet) is still
    # being collected: the pour parts must not wait for the scoop pool.
    ctx = Context("full", tmp_path, False)
    units = {u.key: u for u in plan(ctx, ["supervised3d", "active3d", "confident"])}
    pools = {key: unit for key, unit in units.items() if key.startswith("pool:")}
    assert len(pools) == 2
    for name in ("supervised3d", "active3d"):
        for skill in ("pour", "scoop"):
            part = units[f"{name}:{skill}"]
            assert part.experiment == name and part.part == skill
            (pool,) = part.after
            assert pool.endswith(f"_{skill}") and pool in pools
        # The scoop's θ* trials cost more than the pour's on any engine.
        assert units[f"{name}:scoop"].cost > units[f"{name}:pour"].cost > 0
    assert sorted(units["confident"].after) == sorted(pools)  # one unit: both pools


def test_parallel_parts_append_whole_lines_to_a_shared_job_log(tmp_path: Path) -> None:
    # Two parts of one split experiment share the log; lines larger than any write buffer,
    # written at once from two processes, must come back whole.
    import multiprocessing

    ctx = Context("smoke", tmp_path, False, 1)
    rows = [{"value": float(i), "pad": "x" * 64} for i in range(400)]  # ~30 KB a line
    workers = [multiprocessing.get_context("fork").Process(
        target=_put_many, args=(ctx, prefix, rows)) for prefix in ("pour", "scoop")]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join(60)
        assert worker.exitcode == 0
    log = JobLog(ctx, "exp", {"seeds": 1})
    for prefix in ("pour", "scoop"):
        for job in range(20):
            assert log.get(f"{prefix}/{job}") == rows


def _put_many(ctx: Context, prefix: str, rows: list[dict[str, object]]) -> None:
    log = JobLog(ctx, "exp", {"seeds": 1})
    for job in range(20):
        log.put(f"{prefix}/{job}", rows)


def test_parts_run_alone_without_merging_or_reporting(tmp_path: Path) -> None:
    from bench.paper.__main__ import main

    # An unknown part is one line and exit 2.
    assert main(["--smoke", "--out", str(tmp_path), "--only", "supervised3d", "--parts",
                 "supervised3d:nope", "--no-report", "--jobs", "1"]) == 2
    # The smoke skill's part runs (its pool first), logs its jobs, and writes no experiment
    # JSON (no merge) and no run.json; a later full run reads the jobs back.
    assert main(["--smoke", "--out", str(tmp_path), "--only", "supervised3d", "--parts",
                 "supervised3d:skill8d", "--jobs", "1"]) == 0
    assert not (tmp_path / "supervised3d.json").exists()
    assert not (tmp_path / "run.json").exists()
    logged = (tmp_path / "runs" / "supervised3d-smoke.jsonl").read_text().splitlines()
    assert len(logged) == 5 * 1 + 2 * 1  # learners + the two other kernels, one seed
    ctx = Context("smoke", tmp_path, False, 1)
    from bench.paper import supervised3d

    merged = supervised3d.merge(ctx)
    assert (tmp_path / "runs" / "supervised3d-smoke.jsonl").read_text().splitlines() == logged
    assert merged["skills"]["skill8d"]["summary"]


def test_a_skills_job_log_hash_ignores_the_other_skills_engine() -> None:
    from bench.paper.poollearn import job_sizes
    from bench.paper.supervised3d import SIZES

    full = SIZES["full"]
    moved = {**full, "skill_backends": {**full["skill_backends"], "scoop": "other-engine"}}
    assert job_sizes(moved, "pour") == job_sizes(full, "pour")  # pour's jobs stay valid
    assert job_sizes(moved, "scoop") != job_sizes(full, "scoop")  # scoop's are rerun
    # One engine for every skill: the sizes themselves (committed quick/standard logs valid).
    assert job_sizes(SIZES["quick"], "pour") is SIZES["quick"]
