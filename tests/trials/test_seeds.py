"""Any integer is a seed: negative and huge seeds are hashed, the others kept as given."""

from __future__ import annotations

import json

from ltamp_cli.seeds import SEED_LIMIT, usable_seed
from ltamp_cli.trials.collect import CollectJob, collect


def test_usable_seed_keeps_ordinary_seeds_and_hashes_the_others():
    assert [usable_seed(s) for s in (0, 1, 12345, SEED_LIMIT - 1)] == [0, 1, 12345,
                                                                       SEED_LIMIT - 1]
    odd = [-1, -2, -(2**70), SEED_LIMIT, 10**40]
    mapped = [usable_seed(s) for s in odd]
    assert all(0 <= m < SEED_LIMIT for m in mapped)
    assert len(set(mapped)) == len(odd)  # distinct seeds stay distinct
    assert mapped == [usable_seed(s) for s in odd]  # and deterministic
    assert usable_seed(-1) != 1


def test_collect_with_a_negative_seed_runs_and_resumes(tmp_path):
    out = tmp_path / "t.jsonl"
    job = CollectJob(skill="moving2d", backend="synthetic", n=4, seed=-7)
    assert collect(job, out, progress=False) == 4
    assert collect(CollectJob(skill="moving2d", backend="synthetic", n=6, seed=-7), out,
                   progress=False) == 2
    records = [json.loads(line) for line in out.read_text().splitlines()]
    assert sorted(r["index"] for r in records) == list(range(6))
