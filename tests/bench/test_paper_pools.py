"""Kitchen3D trial pools are drawn like the paper's: uniform random contexts, and controls
redrawn until the skill's pre-check passes (synthetic skill with an invalid corner)."""

from __future__ import annotations

import gzip
import json
import shutil
from pathlib import Path

import numpy as np

from bench.paper.common import Context
from bench.paper.pools import archive_pool, get_pool, restore_pool
from ltamp_cli.backends import load_backend


def test_pool_trials_all_pass_the_precheck_and_resume(tmp_path: Path) -> None:
    ctx = Context("smoke", tmp_path, False, 1)
    pool = get_pool(ctx, "synthetic", "skill8d", 30, 10)
    backend = load_backend("synthetic")
    records = pool.train + pool.test
    assert [r.index for r in records] == list(range(40))
    for r in records:
        assert r.valid
        assert backend.is_valid("skill8d", np.array(r.context), np.array([r.control]))[0]
    stats = pool.stats()
    assert stats["valid_only"] and stats["valid_fraction"] == 1.0
    assert stats["n_train"] == 30 and stats["n_test"] == 10
    # A bigger request resumes the same file: the first 40 trials are unchanged.
    bigger = get_pool(ctx, "synthetic", "skill8d", 45, 5)
    assert [r.control for r in bigger.train[:40]] == [r.control for r in records]
    files = list((tmp_path / "cache" / "pools").glob("*.jsonl"))
    assert [f.name for f in files] == ["synthetic_skill8d_s10000_valid.jsonl"]


def test_pool_archive_restores_a_fresh_cache_and_is_reproducible(tmp_path: Path) -> None:
    ctx = Context("smoke", tmp_path, False, 1)
    first = get_pool(ctx, "synthetic", "skill8d", 12, 3)
    archive = tmp_path / "pools" / "synthetic_skill8d_s10000_valid.jsonl.gz"
    with gzip.open(archive, "rt") as handle:
        lines = [json.loads(line) for line in handle]
    assert [line["index"] for line in lines] == list(range(15))
    assert all(line["backend"] == "synthetic" and line["pool_seed"] == 10_000
               and line["ltamp_version"] and "seed" in line for line in lines)
    packed = archive.read_bytes()
    assert not archive_pool(first.train + first.test, archive)  # same trials: untouched
    # A fresh clone has the archive but no cache: nothing is collected again (a re-run
    # trial would have its own measured wall time).
    shutil.rmtree(tmp_path / "cache")
    again = get_pool(ctx, "synthetic", "skill8d", 12, 3)
    assert [(r.control, r.wall_time_s) for r in again.train + again.test] == [
        (r.control, r.wall_time_s) for r in first.train + first.test]
    assert archive.read_bytes() == packed
    assert restore_pool(archive, tmp_path / "elsewhere.jsonl") == 15
    assert restore_pool(archive, tmp_path / "elsewhere.jsonl") == 0  # nothing missing now
