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

Which engine a skill's pool is collected (and its learners evaluated) on is a mode's choice
(``SIZES[mode]["backend"]``, overridden per skill by ``"skill_backends"``; see
:func:`skill_backend`). ``--full`` takes the cheaper engine, SAPIEN, for a skill only where
the fidelity benchmark's engine row says its labels agree with PyBullet's (the reference
implementation's engine): :func:`engine_agrees` (the 95 % Wilson interval's lower end of the
label agreement >= 0.95 on the committed ``docs/results/fidelity`` row).

While a long collection runs, ``python -m bench.paper.pools --snapshot docs/results/full``
rewrites each archive from the trials collected so far (to commit them as they grow).
"""

from __future__ import annotations

import argparse
import gzip
import importlib.metadata
import json
import os
import sys
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from bench.paper.common import Context
from ltamp_cli.backends.protocol import SkillBackend, SkillSpec
from ltamp_cli.learning.metrics import HeldOutSet
from ltamp_cli.trials.collect import CollectJob, collect
from ltamp_cli.trials.physics import legacy_physics, record_physics
from ltamp_cli.trials.record import TrialDataset, TrialRecord, is_success, training_score

POOL_SEED = 10_000
#: The agreement the fast engine's labels must reach with the reference engine's, as the
#: lower end of the 95 % Wilson interval over the fidelity benchmark's paired inputs.
AGREEMENT_LOWER_BOUND = 0.95
#: The simulator package behind each 3D engine (its version goes into every archived trial).
ENGINE_PACKAGES = {"pybullet": "pybullet", "sapien": "sapien"}


#: ``--full``: the engine each Kitchen3D skill's pool is collected and evaluated on (the
#: experiments' default, ``"backend"``, is PyBullet). SAPIEN where :func:`engine_agrees` on the
#: committed engine row (``docs/results/fidelity/engine.json``; ``tests/bench`` checks that
#: this table follows the rule): pour 197/200 agree, Wilson 0.957-0.995, at 0.21 vs 1.13 s
#: CPU per trial. Scoop stays on PyBullet: its row (SAPIEN scoop physics v3.1, validated on
#: fresh inputs 200-399) has not reached the rule; see ``docs/results/full/README.md``.
FULL_SKILL_BACKENDS: dict[str, str] = {"pour": "sapien", "scoop": "pybullet"}


class SkillBackends:
    """The backends of a mode's skills (:func:`skill_backend`), each loaded once on first
    use (``backends[skill]``) and all closed by :meth:`close`."""

    def __init__(self, sizes: Mapping[str, Any]) -> None:
        self.sizes = sizes
        self._loaded: dict[str, SkillBackend] = {}

    def __getitem__(self, skill: str) -> SkillBackend:
        name = skill_backend(self.sizes, skill)
        if name not in self._loaded:
            from ltamp_cli.backends import load_backend

            self._loaded[name] = load_backend(name)
        return self._loaded[name]

    def close(self) -> None:
        for backend in self._loaded.values():
            backend.close()
        self._loaded.clear()


def backends_label(sizes: Mapping[str, Any]) -> str:
    """``pybullet``, or ``pour: sapien, scoop: pybullet`` when the skills' engines differ."""
    names = {skill: skill_backend(sizes, skill) for skill in sizes["skills"]}
    if len(set(names.values())) <= 1:
        return next(iter(names.values()), str(sizes["backend"]))
    return ", ".join(f"{skill}: {name}" for skill, name in names.items())


def skill_backend(sizes: Mapping[str, Any], skill: str) -> str:
    """The backend ``skill``'s pool is collected and evaluated on under ``sizes`` (a mode's
    row of an experiment's ``SIZES``): ``sizes["skill_backends"][skill]`` when given, else
    ``sizes["backend"]``."""
    return str(dict(sizes.get("skill_backends") or {}).get(skill, sizes["backend"]))


def engine_agrees(row: Mapping[str, Any], bound: float = AGREEMENT_LOWER_BOUND) -> bool:
    """Whether a fidelity engine row (``bench/fidelity.py``'s summary: ``wilson95`` of the
    PyBullet/SAPIEN label agreement) supports collecting on the cheaper engine: the
    interval's lower end is at least ``bound``."""
    return float(row["wilson95"][0]) >= bound


def physics_version(backend: str, skill: str) -> str:
    """``<engine>@v<version>`` of ``skill``'s trials on ``backend`` (PyBullet's or SAPIEN's
    per-skill physics version); ``<backend>@<ltamp version>`` for an engine without one
    (Box2D, synthetic)."""
    if backend == "pybullet":
        from ltamp_cli.backends.pybullet.world import physics_version as pybullet_version

        return f"pybullet@v{pybullet_version(skill)}"
    if backend == "sapien":
        from ltamp_cli.backends.sapien.world import physics_version as sapien_version

        return f"sapien@v{sapien_version(skill)}"
    return f"{backend}@{importlib.metadata.version('ltamp')}"


def engine_version(backend: str) -> str:
    """The installed simulator package's version (``""`` for a backend without one)."""
    package = ENGINE_PACKAGES.get(backend)
    return importlib.metadata.version(package) if package else ""


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
            np.array([training_score(r) for r in self.test]),  # invalid: never a success
        )

    def stats(self) -> dict[str, float | int]:
        scores = np.array([training_score(r) for r in self.train + self.test], dtype=float)
        valid = np.array([r.valid for r in self.train + self.test], dtype=bool)
        return {"n_train": len(self.train), "n_test": len(self.test),
                "valid_fraction": float(valid.mean()) if len(valid) else 0.0,
                "positive_fraction": float(np.mean(scores > 0)) if len(scores) else 0.0,
                "test_positives": int(sum(is_success(r) for r in self.test)),
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
                   if (record := archived_record(json.loads(line))).index not in done]
    dataset.append(missing)
    return len(missing)


def archived_record(line: Mapping[str, Any]) -> TrialRecord:
    """The trial record of an archive line. For an engine with versioned physics the line's
    ``physics_version`` is the trial's physics (``TrialRecord.physics``), so collecting into
    a restored cache under another physics version is refused rather than mixed."""
    record = TrialRecord.from_dict(line)
    if (record.physics is None and legacy_physics(record.backend) is not None
            and isinstance(line.get("physics_version"), str)):
        record = replace(record, physics=line["physics_version"])
    return record


def archive_pool(records: list[TrialRecord], archive: Path) -> bool:
    """Write ``records`` (sorted by index) to the gzip archive, each line a trial record with
    ``pool_seed``, ``ltamp_version``, ``physics_version`` (:func:`physics_version`) and
    ``engine_version`` (:func:`engine_version`) beside its own ``backend`` and ``seed``; atomic
    (temporary file + rename) and byte-for-byte reproducible (gzip mtime 0). Returns False
    (nothing written) when the archive already holds exactly these trials."""
    if archive.is_file():
        with gzip.open(archive, "rt", encoding="utf-8") as handle:
            archived = sorted(json.loads(line)["index"] for line in handle if line.strip())
        if archived == sorted(r.index for r in records):
            return False
    version = importlib.metadata.version("ltamp")
    engines: dict[str, str] = {}
    lines = []
    for record in sorted(records, key=lambda r: r.index):
        data = json.loads(record.to_json())
        if record.backend not in engines:
            engines[record.backend] = engine_version(record.backend)
        # The record's own physics (a trial collected before another physics version keeps
        # its own); the current version only for a record that carries none.
        physics = record_physics(record) or physics_version(record.backend, record.skill)
        data.pop("physics", None)
        data.update(pool_seed=POOL_SEED, ltamp_version=version, physics_version=physics,
                    engine_version=engines[record.backend])
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


def snapshot(out: Path) -> dict[str, int]:
    """Rewrite every archive ``<out>/pools/<name>.jsonl.gz`` from the trials collected so far
    in ``<out>/cache/pools/<name>.jsonl`` (the archive's trials are restored into the cache
    file first, so a snapshot never loses archived trials); safe while a collection appends
    to the cache file (a torn last line is skipped). Returns trials per archive name."""
    counts: dict[str, int] = {}
    for path in sorted((out / "cache" / "pools").glob("*.jsonl")):
        archive = out / "pools" / f"{path.stem}.jsonl.gz"
        by_index = {r.index: r for r in _read_complete(path)}
        if archive.is_file():
            with gzip.open(archive, "rt", encoding="utf-8") as handle:
                for line in handle:
                    if line.strip():
                        record = archived_record(json.loads(line))
                        by_index.setdefault(record.index, record)
        archive_pool(list(by_index.values()), archive)
        counts[path.stem] = len(by_index)
    return counts


def _read_complete(path: Path) -> list[TrialRecord]:
    """The whole-line records of a trial file another process may be appending to."""
    records = []
    with path.open(encoding="utf-8") as handle:
        for line in handle:
            if not line.endswith("\n"):
                break  # being written
            try:
                records.append(TrialRecord.from_dict(json.loads(line)))
            except (json.JSONDecodeError, KeyError, TypeError, ValueError):
                continue
    return records


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.paper.pools",
                                     description=snapshot.__doc__)
    parser.add_argument("--snapshot", type=Path, required=True, metavar="OUT",
                        help="results folder, e.g. docs/results/full")
    args = parser.parse_args(argv)
    if not (args.snapshot / "cache" / "pools").is_dir():
        print(f"--snapshot: no trial pools under {args.snapshot / 'cache' / 'pools'}",
              file=sys.stderr)
        return 2
    for name, count in snapshot(args.snapshot).items():
        print(f"{name}: {count} trials archived")
    return 0


if __name__ == "__main__":
    sys.exit(main())
