"""``--full``'s trial pools: each Kitchen3D skill's engine follows the fidelity rule on the
committed engine rows, committed pool archives restore a fresh clone's cache without
simulating a trial, and a SAPIEN pool trial depends only on the pool seed and its index."""

from __future__ import annotations

import gzip
import importlib
import json
import shutil
from pathlib import Path
from typing import Any

import pytest

import ltamp_cli.trials.collect as collect_module
from bench.paper.__main__ import POOLED, plan
from bench.paper.common import REPO, Context
from bench.paper.pools import (
    FULL_SKILL_BACKENDS,
    POOL_SEED,
    engine_agrees,
    get_pool,
    physics_version,
    skill_backend,
    snapshot,
)
from ltamp_cli.trials.collect import CollectJob, collect, trial_seed
from ltamp_cli.trials.record import TrialDataset

FIDELITY = REPO / "docs" / "results" / "fidelity" / "engine.json"
FULL_POOLS = REPO / "docs" / "results" / "full" / "pools"


def test_engine_rule_is_the_wilson_lower_end() -> None:
    assert engine_agrees({"wilson95": [0.9568, 0.9949]})
    assert not engine_agrees({"wilson95": [0.9499, 0.99]})  # point estimate may be >= 0.95


def test_full_engines_follow_the_rule_on_the_committed_engine_rows(tmp_path: Path) -> None:
    rows = {row["skill"]: row for row in json.loads(FIDELITY.read_text())["rows"]}
    for skill, backend in FULL_SKILL_BACKENDS.items():
        assert backend == ("sapien" if engine_agrees(rows[skill]) else "pybullet"), skill
    for name in POOLED:
        sizes = importlib.import_module(f"bench.paper.{name}").SIZES["full"]
        assert {s: skill_backend(sizes, s) for s in sizes["skills"]} == FULL_SKILL_BACKENDS
    units = plan(Context("full", tmp_path, False, 1), list(POOLED), pools_only=True)
    assert sorted(u.key for u in units) == sorted(
        f"pool:{backend}_{skill}" for skill, backend in FULL_SKILL_BACKENDS.items())
    assert all(u.part.endswith(":10000") for u in units)  # the paper's 10,000 per skill


def test_committed_full_pools_restore_without_simulating(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    archives = sorted(FULL_POOLS.glob("*_s10000_valid.jsonl.gz"))
    assert archives, f"no committed --full pool under {FULL_POOLS}"

    def no_trials(*_args: Any, **_kwargs: Any) -> Any:
        raise AssertionError("a committed trial was simulated again")

    monkeypatch.setattr(collect_module, "_run_guarded", no_trials)  # every trial runs here
    ctx = Context("full", tmp_path, False, 1)  # a fresh clone: archives, no cache
    (tmp_path / "pools").mkdir()
    for archive in archives:
        shutil.copy(archive, tmp_path / "pools" / archive.name)
        with gzip.open(archive, "rt", encoding="utf-8") as handle:
            lines = [json.loads(line) for line in handle if line.strip()]
        backend, skill = archive.name.split("_")[:2]
        assert [line["index"] for line in lines] == list(range(len(lines)))
        for line in lines:
            assert line["backend"] == backend and line["skill"] == skill
            assert line["seed"] == trial_seed(POOL_SEED, line["index"])
            assert line["pool_seed"] == POOL_SEED and line["engine_version"]
            # Collected under today's physics (a physics change would make the pool stale).
            assert line["physics_version"] == physics_version(backend, skill)
        pool = get_pool(ctx, backend, skill, len(lines), 0)
        assert [(r.index, r.control, r.score) for r in pool.train] == [
            (line["index"], tuple(line["control"]),
             line["score"] if line["score"] is not None else pool.train[i].score)
            for i, line in enumerate(lines)]
        assert (tmp_path / "pools" / archive.name).read_bytes() == archive.read_bytes()


def test_sapien_pool_trial_depends_only_on_seed_and_index(tmp_path: Path) -> None:
    pytest.importorskip("sapien")
    job = CollectJob(skill="pour", backend="sapien", n=2, seed=POOL_SEED, valid_only=True)
    whole, resumed = tmp_path / "whole.jsonl", tmp_path / "resumed.jsonl"
    collect(job, whole, workers=1, progress=False)
    first = {r.index: r for r in TrialDataset(whole).read()}
    # Resuming after trial 0 runs trial 1 alone, in a fresh process state: same trial.
    TrialDataset(resumed).append(first[0])
    assert collect(job, resumed, workers=1, progress=False) == 1
    again = {r.index: r for r in TrialDataset(resumed).read()}
    for key in ("context", "control", "seed", "valid", "score"):
        assert getattr(again[1], key) == getattr(first[1], key), key


def test_snapshot_archives_what_is_collected_so_far(tmp_path: Path) -> None:
    ctx = Context("smoke", tmp_path, False, 1)
    get_pool(ctx, "synthetic", "skill8d", 6, 0)
    cache = tmp_path / "cache" / "pools" / "synthetic_skill8d_s10000_valid.jsonl"
    archive = tmp_path / "pools" / "synthetic_skill8d_s10000_valid.jsonl.gz"
    collect(CollectJob(skill="skill8d", backend="synthetic", n=9, seed=POOL_SEED,
                       valid_only=True), cache, workers=1, progress=False)
    with cache.open("a") as handle:
        handle.write('{"skill": "skill8d", "index": 9')  # a line still being written
    assert snapshot(tmp_path) == {"synthetic_skill8d_s10000_valid": 9}
    with gzip.open(archive, "rt") as handle:
        assert [json.loads(line)["index"] for line in handle] == list(range(9))


def test_full_sizes_are_the_papers_and_only_five_seeds_simulate_the_success_rate() -> None:
    from bench.paper.poollearn import success_checkpoints

    # ltamp-paper.tex section 6.1-6.2: F1 on 10 shuffles of 400 training / 1,000 test trials;
    # success rate on 5 shuffles, every 10 trials up to 200, 45 contexts; 200 repetitions.
    for name in POOLED:
        sizes = importlib.import_module(f"bench.paper.{name}").SIZES["full"]
        if "success_at" not in sizes:
            continue
        assert (sizes["seeds"], sizes["budget"], sizes["n_test"]) == (10, 400, 1000), name
        assert (sizes["success_seeds"], sizes["contexts"]) == (5, 45), name
        assert sizes["success_at"] == list(range(10, 201, 10)), name
        assert [len(success_checkpoints(sizes, seed)) for seed in range(10)] == [20] * 5 + [0] * 5
        if "reps" in sizes:
            assert sizes["reps"] == 200
    quick = importlib.import_module("bench.paper.supervised3d").SIZES["quick"]
    assert success_checkpoints(quick, quick["seeds"] - 1) == set(quick["success_at"])
