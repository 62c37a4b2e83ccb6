"""Random trial pools for the Kitchen3D experiments (2, 3 and 6), collected with ``ltamp collect``.

The paper drew 10,000 pour and scoop trials with uniformly random contexts and controls and
used them for the non-active learners, the held-out test sets and pool-mode ("discrete")
active learning. Its collector (the public LTAMP code, ``get_parameter_fns`` with ``valid``
on) redrew a trial's random control until the skill's hard-constraint check passed, so the
pool is uniform over the *pre-check-valid* controls; we do the same (``ltamp collect
--valid-only``): a control that fails the pre-check is known to fail without simulating it,
and a pool of such trials would teach nothing the pre-check does not already say.

We regenerate the pools from a seed with :func:`ltamp_cli.trials.collect.collect` (the function
behind ``ltamp collect``: parallel workers, append-only, resumable) into
``<out>/cache/pools/<backend>_<skill>_s<seed>_valid.jsonl``. Trial ``i`` depends only on the seed
and ``i``, so a bigger mode resumes a smaller one's file. The first ``n_train`` trials form the
pool, the next ``n_test`` the held-out test set.
"""

from __future__ import annotations

import gzip
import importlib.metadata
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench.paper.common import Context
from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.learning.metrics import HeldOutSet
from ltamp_cli.trials.collect import CollectJob, collect
from ltamp_cli.trials.record import TrialDataset, TrialRecord

POOL_SEED = 10_000


@dataclass(frozen=True)
class Pool:
    """Training pool and held-out test trials of one skill."""

    backend: str
    skill: str
    train: list[TrialRecord]
    test: list[TrialRecord]
    valid_only: bool = True

    def heldout(self) -> HeldOutSet:
        """The test trials as a held-out set (physical contexts/controls and true scores)."""
        return HeldOutSet(
            np.array([r.context for r in self.test], dtype=float),
            np.array([r.control for r in self.test], dtype=float),
            np.array([r.score if np.isfinite(r.score) else -1.0 for r in self.test]),
        )

    def stats(self) -> dict[str, float | int]:
        scores = np.array([r.score for r in self.train + self.test], dtype=float)
        valid = np.array([r.valid for r in self.train + self.test], dtype=bool)
        return {"n_train": len(self.train), "n_test": len(self.test),
                "valid_fraction": float(valid.mean()) if len(valid) else 0.0,
                "positive_fraction": float(np.mean(scores > 0)) if len(scores) else 0.0,
                "test_positives": int(sum(r.score > 0 for r in self.test)),
                "valid_only": self.valid_only}


def get_pool(ctx: Context, backend: str, skill: str, n_train: int, n_test: int) -> Pool:
    """Collect (or resume) ``n_train + n_test`` uniform random pre-check-valid trials and
    split them.

    The trials are also kept as a committed archive, ``<out>/pools/<name>.jsonl.gz``: a fresh
    clone restores its cache from it and collects only the trials the archive lacks, and the
    archive is rewritten (deterministically: same trials, same bytes) whenever collection adds
    trials.
    """
    folder = ctx.cache / "pools"
    folder.mkdir(parents=True, exist_ok=True)
    name = f"{backend}_{skill}_s{POOL_SEED}_valid"
    path = folder / f"{name}.jsonl"
    archive = ctx.out / "pools" / f"{name}.jsonl.gz"
    restore_pool(archive, path)
    n = n_train + n_test
    job = CollectJob(skill=skill, backend=backend, n=n, seed=POOL_SEED, valid_only=True)
    collect(job, path, workers=ctx.workers if backend != "synthetic" else 1,
            progress=ctx.progress)
    by_index = {r.index: r for r in TrialDataset(path).read() if r.skill == skill}
    archive_pool(list(by_index.values()), archive)
    records = [by_index[i] for i in range(n) if i in by_index]
    return Pool(backend, skill, records[:n_train], records[n_train:n])


def restore_pool(archive: Path, path: Path) -> int:
    """Append to the trial file ``path`` the archived trials it lacks (by index); returns
    how many. Archive lines are trial records plus provenance keys, read as data."""
    if not archive.is_file():
        return 0
    dataset = TrialDataset(path)
    done = dataset.done_indices()
    with gzip.open(archive, "rt", encoding="utf-8") as handle:
        missing = [record for line in handle if line.strip()
                   if (record := TrialRecord.from_dict(json.loads(line))).index not in done]
    dataset.append(missing)
    return len(missing)


def archive_pool(records: list[TrialRecord], archive: Path) -> bool:
    """Write ``records`` (sorted by index) to the gzip archive, each line a trial record with
    ``pool_seed`` and ``ltamp_version`` beside its own ``backend`` and ``seed``; atomic
    (temporary file + rename) and byte-for-byte reproducible (gzip mtime 0). Returns False
    (nothing written) when the archive already holds exactly these trials."""
    if archive.is_file():
        with gzip.open(archive, "rt", encoding="utf-8") as handle:
            archived = sorted(json.loads(line)["index"] for line in handle if line.strip())
        if archived == sorted(r.index for r in records):
            return False
    version = importlib.metadata.version("ltamp")
    lines = []
    for record in sorted(records, key=lambda r: r.index):
        data = json.loads(record.to_json())
        data.update(pool_seed=POOL_SEED, ltamp_version=version)
        lines.append(json.dumps(data, sort_keys=True) + "\n")
    archive.parent.mkdir(parents=True, exist_ok=True)
    partial = archive.with_name(archive.name + ".partial")
    with partial.open("wb") as raw, gzip.GzipFile(fileobj=raw, mode="wb", mtime=0) as handle:
        handle.write("".join(lines).encode("utf-8"))
    os.replace(partial, archive)
    return True


def spec_of(backend_name: str, skill: str) -> SkillSpec:
    from ltamp_cli.backends import load_backend

    backend = load_backend(backend_name)
    try:
        return backend.skills()[skill]
    finally:
        backend.close()
