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

from dataclasses import dataclass

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
    split them."""
    folder = ctx.cache / "pools"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{backend}_{skill}_s{POOL_SEED}_valid.jsonl"
    n = n_train + n_test
    job = CollectJob(skill=skill, backend=backend, n=n, seed=POOL_SEED, valid_only=True)
    collect(job, path, workers=ctx.workers if backend != "synthetic" else 1,
            progress=ctx.progress)
    by_index = {r.index: r for r in TrialDataset(path).read() if r.skill == skill}
    records = [by_index[i] for i in range(n) if i in by_index]
    return Pool(backend, skill, records[:n_train], records[n_train:n])


def spec_of(backend_name: str, skill: str) -> SkillSpec:
    from ltamp_cli.backends import load_backend

    backend = load_backend(backend_name)
    try:
        return backend.skills()[skill]
    finally:
        backend.close()
