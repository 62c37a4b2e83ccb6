"""Diagnose PyBullet vs SAPIEN scoop disagreements: per trial, both engines' measured spoon
capacity, beads in the spoon over time, where the beads end up.

Reads the ``3d-scoop-engine`` pairs from a ``bench/fidelity.py`` cache, picks the inputs
whose labels disagree (or ``--indices``), re-runs each on both engines with a recording
physics wrapper and writes one JSON line per (input, engine) to ``--out``.

    OMP_NUM_THREADS=1 .venv/bin/python bench/scoop_engine_diag.py \
        --cache docs/results/fidelity/engine_trials_v2.jsonl \
        --out docs/results/fidelity/scoop_diag.jsonl

``--capacity`` measures only the spoon's capacity (:func:`measure_spoon_capacity`, the same
draws as the trial's) of inputs ``--first``..``--last - 1`` of the cache, on one engine
(``--engines``, one name) with SAPIEN settings ``--config`` (JSON of
:class:`SapienWorldConfig` fields): one JSON line per input, a fraction of a second each.
This is how SAPIEN physics version 3.1's spoon was fitted (issue #21, inputs 0-59):

    OMP_NUM_THREADS=1 .venv/bin/python bench/scoop_engine_diag.py --capacity \
        --cache docs/results/fidelity/engine_scoop_bed_trials.jsonl --first 0 --last 60 \
        --engines sapien --config '{"spoon_tool": "placed"}' \
        --out docs/results/fidelity/scoop_capacity_fit.jsonl

``--rerun INPUTS`` re-runs ``--indices`` of a stored-inputs file (``bench/fidelity.py
--inputs``; trial seed = index) on ``--engines`` as shipped (SAPIEN with ``--config``) in
this process and writes one line per trial with the score, the cached score of the same key
and the trial's ``info`` (capacity, beads in the spoon); resumable. Issue #21's staleness
check (are the cached labels what today's code gives?):

    OMP_NUM_THREADS=1 .venv/bin/python bench/scoop_engine_diag.py --rerun \
        docs/results/fidelity/engine_scoop_inputs.json \
        --cache docs/results/fidelity/engine_scoop_bed_trials.jsonl --engines pybullet \
        --indices $(seq 0 5 195) --out docs/results/fidelity/scoop_rerun_pybullet.jsonl

``--fit-summary RERUN.jsonl ...`` summarises ``--rerun`` lines per SAPIEN setting against
the cached PyBullet and SAPIEN v3 labels (:func:`fit_summary`): issue #21's third attempt,
the engine settings screened on 32 borderline inputs of the fit set 0-199:

    OMP_NUM_THREADS=1 .venv/bin/python bench/scoop_engine_diag.py --fit-summary \
        docs/results/fidelity/scoop_fit_engine_settings.jsonl \
        --capacities docs/results/fidelity/scoop_capacity_pybullet_borderline.jsonl \
        --cache docs/results/fidelity/engine_scoop_bed_trials.jsonl \
        --out docs/results/fidelity/scoop_fit_engine_settings_summary.json

``--compare-sets 0 200 400 ...`` compares the cached pairs of consecutive index ranges
(:func:`compare_sets`: successes, disagreements, KS per input and latent dimension, a
two-sample classifier, a logistic model of disagreement with a set indicator) and writes
the JSON report to ``--out``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from bench.fidelity import setting_version, trial_key
from ltamp_cli.backends import load_backend
from ltamp_cli.backends.pybullet.skills.physics import BulletTrialPhysics
from ltamp_cli.backends.pybullet.world import PhysicsWorld
from ltamp_cli.backends.sapien.skills import SapienTrialPhysics
from ltamp_cli.backends.sapien.world import SapienWorld, SapienWorldConfig
from ltamp_cli.backends.skills3d.physics import contained_mask
from ltamp_cli.backends.skills3d.scoop import (
    SCOOP_CONTEXT,
    SCOOP_CONTROL,
    SCOOP_TAU,
    ScoopContext,
    ScoopSettings,
    measure_spoon_capacity,
    prepare_scoop,
    run_scoop,
    sample_scoop_latents,
)


@dataclass
class Recorder:
    """Delegates to an engine's trial physics and remembers the last tool and beads."""

    inner: Any
    tools: list[Any] = field(default_factory=list)
    beads: list[Any] = field(default_factory=list)
    series: list[tuple[int, int]] = field(default_factory=list)
    every: int = 24

    @property
    def time_step(self) -> float:
        return float(self.inner.time_step)

    def reset(self) -> None:
        self.inner.reset()

    def steps_for(self, seconds: float) -> int:
        return int(self.inner.steps_for(seconds))

    def add_body(self, geometry: Any, material: Any, role: Any, *args: Any) -> Any:
        body = self.inner.add_body(geometry, material, role, *args)
        if role == "tool":
            self.tools.append(body)
        return body

    def spawn_beads_in(self, container: Any, spec: Any, rng: np.random.Generator) -> Any:
        beads = self.inner.spawn_beads_in(container, spec, rng)
        self.beads.append(beads)
        return beads

    def _record(self, step: int) -> None:
        if step % self.every == 0 and len(self.beads) >= 2:
            n = int(contained_mask(self.tools[-1], self.beads[-1].positions()).sum())
            self.series.append((step, n))

    def follow(self, tool: Any, path: Any, on_step: Any = None, step_offset: int = 0) -> int:
        return int(self.inner.follow(tool, path, self._record, step_offset))

    def hold(self, tool: Any, position: Any, quaternion: Any, steps: int, on_step: Any = None,
             step_offset: int = 0) -> int:
        return int(self.inner.hold(tool, position, quaternion, steps, self._record,
                                   step_offset))


def engine_physics(name: str, **config: Any) -> Any:
    if name == "pybullet":
        return BulletTrialPhysics(PhysicsWorld())
    return SapienTrialPhysics(SapienWorld(SapienWorldConfig(**config)))


def disagreeing(cache: Path, versions: dict[str, str] | None = None) -> list[dict]:
    """The cache's scoop pairs (PyBullet, SAPIEN) by input index, with their scores and
    whether the labels agree. ``versions``: the physics version of each engine's trials to
    pair (default: the current ones, :func:`bench.fidelity.setting_version`); a cache keeps
    the trials of older versions too (e.g. ``sapien@v3`` and ``sapien@v3.1``)."""
    versions = versions or {name: str(setting_version(name, "scoop"))
                            for name in ("pybullet", "sapien")}
    rows: dict[int, dict[str, dict]] = {}
    for line in cache.open():
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            continue  # a torn last line of a running benchmark
        setting = record.get("setting")
        if (record["skill"] == "scoop" and setting in versions
                and record["key"].startswith(f"{setting}@v{versions[setting]}|")):
            rows.setdefault(record["seed"], {})[setting] = record
    out = []
    for seed, pair in sorted(rows.items()):
        if len(pair) == 2:
            labels = [p["valid"] and p["score"] > 0 for p in pair.values()]
            out.append({"index": seed, "context": pair["pybullet"]["context"],
                        "control": pair["pybullet"]["control"],
                        "agree": labels[0] == labels[1],
                        "scores": {k: v["score"] for k, v in pair.items()}})
    return out


def capacity_rows(cache: Path, first: int, last: int, engine: str, config: dict[str, Any],
                  indices: list[int] | None = None) -> Iterator[dict[str, Any]]:
    """The spoon capacity (beads) of inputs ``first..last-1`` of ``cache``'s scoop pairs
    (indices = trial seeds of seed 0; ``indices``: these instead) on ``engine``, measured as
    in the trial (same latents and draws), with the spoon and bead masses (kg) and the bead
    radius (m), one row per input as soon as it is measured."""
    by_index = _cached_by_seed(cache, f"pybullet@v{setting_version('pybullet', 'scoop')}|")
    physics = engine_physics(engine, **config)
    settings = ScoopSettings()
    for index in (range(first, last) if indices is None else indices):
        item = by_index[index]
        trial = prepare_scoop(np.array(item["context"]), np.array(item["control"]), False)
        rng = np.random.default_rng(index)
        latents = sample_scoop_latents(rng, settings, trial.scene.bowl)
        capacity = measure_spoon_capacity(physics, trial.tool, latents.beads,
                                          latents.spoon_material, rng, settings.settle_s)
        yield {"index": index, "engine": engine, "cfg": config, "capacity": capacity,
               "spoon_mass": latents.spoon_material.mass,
               "bead_mass": latents.beads.mass, "radius": latents.beads.radius}


def rerun_rows(inputs_path: Path, cache: Path, indices: list[int], engine: str,
               done: set[tuple[int, str]], config: dict[str, Any] | None = None
               ) -> Iterator[dict[str, Any]]:
    """Re-run the ``3d-scoop-engine`` trials of ``indices`` (inputs of ``inputs_path``, trial
    seed = index) on ``engine`` as shipped (``load_backend``), in this process, and yield
    per trial: the score, the full ``info`` (capacity, beads in the spoon, lost), the CPU
    seconds and the score the cache holds for the same key (``None`` if absent).
    ``done``: (index, engine) pairs to skip (a resumed run)."""
    stored = json.loads(inputs_path.read_text())["inputs"]
    setting = engine
    cached = {}
    for line in cache.open():
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            continue
        cached[record["key"]] = record
    backend = load_backend(engine)
    if config:
        backend.config = replace(backend.config, **config)  # type: ignore[attr-defined]
    try:
        for index in indices:
            if (index, engine) in done:
                continue
            row = np.asarray(stored[index], dtype=float)
            context, control = row[:4], row[4:]
            key = trial_key(setting, "scoop", context, control, index)
            start = time.process_time()
            result = backend.run_trial("scoop", context, control, index)
            old = cached.get(key)
            yield {"index": index, "engine": engine, "key_version": key.split("|")[0],
                   "cfg": config or {},
                   "score": float(result.score), "valid": bool(result.valid),
                   "cached_score": None if old is None else old["score"],
                   "info": {k: v for k, v in result.info.items()
                            if isinstance(v, int | float | str | None)},
                   "cpu_s": time.process_time() - start}
    finally:
        backend.close()


def _cached_by_seed(cache: Path, prefix: str) -> dict[int, dict]:
    """The cache's scoop records whose key starts with ``prefix`` (e.g. ``sapien@v3|``), by
    trial seed (= input index)."""
    records: dict[int, dict] = {}
    for line in cache.open():
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            continue
        if record["skill"] == "scoop" and record["key"].startswith(prefix):
            records[record["seed"]] = record
    return records


def fit_summary(reruns: list[Path], cache: Path, capacities: Path | None) -> list[dict]:
    """Per SAPIEN setting (``cfg``) of ``--rerun`` lines: on its inputs, how many labels
    agree with PyBullet's (cached) for that setting and for the cached SAPIEN v3, the mean
    clipped fraction-of-capacity bias over PyBullet (both), and, with PyBullet capacities
    (``--capacity --engines pybullet`` lines), the mean SAPIEN/PyBullet capacity ratio and
    the mean spoonful difference (beads; PyBullet's spoonful = its clipped fraction × its
    capacity, so spoonfuls above capacity count as full); ``_v3`` keys: the same for the
    re-run of SAPIEN v3 (``cfg`` ``{}``); both on the inputs that re-run covers."""
    pybullet = _cached_by_seed(cache, f"pybullet@v{setting_version('pybullet', 'scoop')}|")
    sapien_v3 = _cached_by_seed(cache, "sapien@v3|")
    capacity = {}
    if capacities is not None:
        for line in capacities.open():
            row = json.loads(line)
            capacity[row["index"]] = row["capacity"]
    groups: dict[str, dict[int, dict]] = {}
    for path in reruns:
        for line in path.open():
            row = json.loads(line)
            groups.setdefault(json.dumps(row["cfg"], sort_keys=True), {})[row["index"]] = row

    def label(score: float, valid: bool) -> bool:
        return bool(valid) and score > 0

    def fraction(score: float, valid: bool) -> float:
        return fraction_from_score(score) if valid else 0.0

    out = []
    for cfg, rows in groups.items():
        indices = sorted(i for i in rows if i in pybullet and i in sapien_v3)
        ref = [pybullet[i] for i in indices]
        old = [sapien_v3[i] for i in indices]
        new = [rows[i] for i in indices]
        summary: dict[str, Any] = {
            "cfg": json.loads(cfg), "inputs": len(indices),
            "agree_new": sum(label(n["score"], n["valid"]) == label(r["score"], r["valid"])
                             for n, r in zip(new, ref, strict=True)),
            "agree_v3": sum(label(o["score"], o["valid"]) == label(r["score"], r["valid"])
                            for o, r in zip(old, ref, strict=True)),
            "fraction_bias_new": float(np.mean([
                fraction(n["score"], n["valid"]) - fraction(r["score"], r["valid"])
                for n, r in zip(new, ref, strict=True)])) if indices else None,
            "fraction_bias_v3": float(np.mean([
                fraction(o["score"], o["valid"]) - fraction(r["score"], r["valid"])
                for o, r in zip(old, ref, strict=True)])) if indices else None,
        }
        # The same measures for SAPIEN v3 (the re-run of cfg {}) on the same inputs.
        v3_rows = groups.get("{}", {})
        for name, source in (("", rows), ("_v3", v3_rows)):
            measured = [i for i in indices if i in capacity and i in source
                        and (not v3_rows or i in v3_rows)]
            if measured:
                summary[f"capacity_inputs{name}"] = len(measured)
                summary[f"capacity_ratio{name}"] = float(np.mean(
                    [source[i]["info"]["spoon_capacity"] / capacity[i] for i in measured]))
                summary[f"spoonful_diff_beads{name}"] = float(np.mean(
                    [source[i]["info"]["beads_in_spoon_end"]
                     - fraction(pybullet[i]["score"], pybullet[i]["valid"]) * capacity[i]
                     for i in measured]))
        out.append(summary)
    return out


#: The latent draws of a scoop trial compared across input sets (:func:`compare_sets`).
LATENT_NAMES = ("bead_count", "bead_radius_m", "bead_mass_kg", "bead_friction",
                "bead_restitution", "bowl_friction", "spoon_mass_kg", "spoon_friction",
                "spoon_restitution")


def scoop_latents(context: np.ndarray, index: int) -> list[float]:
    """The trial's latent draws (:data:`LATENT_NAMES`) of input ``index`` (trial seed)."""
    latents = sample_scoop_latents(np.random.default_rng(index), ScoopSettings(),
                                   ScoopContext.from_array(context).bowl)
    beads = latents.beads
    return [beads.count, beads.radius, beads.mass, beads.lateral_friction, beads.restitution,
            latents.bowl_material.lateral_friction, latents.spoon_material.mass,
            latents.spoon_material.lateral_friction, latents.spoon_material.restitution]


def fraction_from_score(score: float) -> float:
    """The clipped fraction of capacity ``x`` in ``[0, 1]`` of a scoop score ``g(x; τ)``."""
    return (score + 1.0) * SCOOP_TAU if score <= 0 else SCOOP_TAU + score * (1.0 - SCOOP_TAU)


def compare_sets(inputs_path: Path, cache: Path, sets: list[tuple[int, int]]
                 ) -> dict[str, Any]:
    """Are the ``3d-scoop-engine`` pairs of the index ranges ``sets`` alike? Per set: both
    engines' successes and the disagreements, the fraction-of-capacity histograms; between
    the first set and each other one: KS p-values per input and latent dimension, a
    random-forest two-sample test (10-fold CV AUC of telling the sets apart from inputs and
    latents; 0.5 = alike), Fisher's exact test of the disagreement counts, and a logistic
    model of disagreement on the strongest covariates with and without a set indicator
    (likelihood-ratio p-value: whether the covariates explain the sets' difference)."""
    from scipy.stats import chi2, fisher_exact, ks_2samp
    from sklearn.ensemble import RandomForestClassifier
    from sklearn.linear_model import LogisticRegression
    from sklearn.model_selection import cross_val_score

    stored = np.asarray(json.loads(inputs_path.read_text())["inputs"], dtype=float)
    pairs = {p["index"]: p for p in disagreeing(cache)}
    report: dict[str, Any] = {"sets": []}
    per_set = []
    for first, last in sets:
        idx = [i for i in range(first, last) if i in pairs]
        fp = np.array([fraction_from_score(pairs[i]["scores"]["pybullet"]) for i in idx])
        fs = np.array([fraction_from_score(pairs[i]["scores"]["sapien"]) for i in idx])
        feats = np.array([[*stored[i], *scoop_latents(stored[i][:4], i)] for i in idx])
        per_set.append((idx, fp, fs, feats))
        bins = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 1.01]
        report["sets"].append({
            "inputs": [first, last - 1], "pairs": len(idx),
            "pybullet_successes": int((fp > SCOOP_TAU).sum()),
            "sapien_successes": int((fs > SCOOP_TAU).sum()),
            "sapien_only": int(((fs > SCOOP_TAU) & (fp <= SCOOP_TAU)).sum()),
            "pybullet_only": int(((fp > SCOOP_TAU) & (fs <= SCOOP_TAU)).sum()),
            "mean_fraction": {"pybullet": float(fp.mean()), "sapien": float(fs.mean())},
            "fraction_bins": bins[:-1],
            "fraction_hist": {"pybullet": np.histogram(fp, bins)[0].tolist(),
                              "sapien": np.histogram(fs, bins)[0].tolist()}})
    names = [*SCOOP_CONTEXT.names, *SCOOP_CONTROL.names, *LATENT_NAMES]
    _, fp0, fs0, f0 = per_set[0]
    report["versus_first"] = []
    for k in range(1, len(per_set)):
        _, fp1, fs1, f1 = per_set[k]
        features = np.concatenate([f0, f1])
        which = np.r_[np.zeros(len(f0)), np.ones(len(f1))]
        auc = cross_val_score(RandomForestClassifier(300, random_state=0, min_samples_leaf=5),
                              features, which, cv=10, scoring="roc_auc").mean()
        dis = np.r_[(fp0 > SCOOP_TAU) != (fs0 > SCOOP_TAU), (fp1 > SCOOP_TAU) != (fs1 > SCOOP_TAU)]
        table = [[int(dis[:len(f0)].sum()), len(f0) - int(dis[:len(f0)].sum())],
                 [int(dis[len(f0):].sum()), len(f1) - int(dis[len(f0):].sum())]]
        chosen = ["scoop_z", "spoon_length", "start_y", "bead_mass_kg", "spoon_mass_kg"]
        cov = features[:, [names.index(c) for c in chosen]]
        cov = (cov - cov.mean(0)) / cov.std(0)

        def loglik(design: np.ndarray, labels: np.ndarray = dis) -> float:
            model = LogisticRegression(C=1e6, max_iter=5000).fit(design, labels)
            p = np.clip(model.predict_proba(design)[:, 1], 1e-12, 1 - 1e-12)
            return float(np.sum(labels * np.log(p) + (1 - labels) * np.log(1 - p)))

        base, with_set = loglik(cov), loglik(np.c_[cov, which])
        report["versus_first"].append({
            "sets": [report["sets"][0]["inputs"], report["sets"][k]["inputs"]],
            "ks_p": {n: float(ks_2samp(f0[:, j], f1[:, j]).pvalue)
                     for j, n in enumerate(names)},
            "two_sample_rf_auc": float(auc),
            "disagreements_fisher_p": float(fisher_exact(table)[1]),
            "logistic_covariates": chosen,
            "set_effect_given_covariates_lr_p": float(chi2.sf(2 * (with_set - base), 1))})
    return report


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--indices", type=int, nargs="*", default=None)
    parser.add_argument("--engines", nargs="*", default=["pybullet", "sapien"])
    parser.add_argument("--capacity", action="store_true",
                        help="measure only the spoon capacity of inputs --first..--last-1")
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--last", type=int, default=60)
    parser.add_argument("--config", default="{}", help="SAPIEN settings (JSON)")
    parser.add_argument("--rerun", type=Path, default=None, metavar="INPUTS_JSON",
                        help="re-run --indices of this stored-inputs file on --engines as "
                             "shipped and compare with the cached scores (resumable)")
    parser.add_argument("--compare-sets", type=int, nargs="+", default=None,
                        metavar="BOUND", help="compare the cached pairs of index ranges "
                        "BOUND[0]..BOUND[1]-1, BOUND[1]..BOUND[2]-1, ... (needs --rerun's "
                        "inputs file as --inputs); writes JSON to --out")
    parser.add_argument("--inputs", type=Path, default=None, help="stored inputs (JSON)")
    parser.add_argument("--fit-summary", type=Path, nargs="+", default=None,
                        metavar="RERUN_JSONL", help="summarise --rerun lines per SAPIEN "
                        "setting against the cache's PyBullet and SAPIEN v3 labels "
                        "(:func:`fit_summary`; PyBullet capacities from --capacities)")
    parser.add_argument("--capacities", type=Path, default=None,
                        help="PyBullet --capacity lines for --fit-summary")
    parser.add_argument("--sapien-version", default=None,
                        help="pair the cache's SAPIEN trials of this physics version "
                             "(default: the current one), e.g. 3 for the v3 row")
    args = parser.parse_args(argv)
    if args.fit_summary is not None:
        summaries = fit_summary(args.fit_summary, args.cache, args.capacities)
        args.out.write_text(json.dumps(summaries, indent=1))
        for row in summaries:
            print(json.dumps(row))
        return 0
    if args.compare_sets is not None:
        if args.inputs is None or len(args.compare_sets) < 3:
            parser.error("--compare-sets needs --inputs and at least 3 bounds")
        bounds = args.compare_sets
        report = compare_sets(args.inputs, args.cache, list(itertools.pairwise(bounds)))
        args.out.write_text(json.dumps(report, indent=1))
        print(json.dumps(report["versus_first"], indent=1))
        return 0
    if args.rerun is not None:
        done = set()
        if args.out.exists():
            for line in args.out.open():
                try:
                    record = json.loads(line)
                except json.JSONDecodeError:
                    continue
                done.add((record["index"], record["engine"]))
        for engine in args.engines:
            config = json.loads(args.config) if engine == "sapien" else {}
            for row in rerun_rows(args.rerun, args.cache, args.indices or [], engine, done,
                                  config):
                with args.out.open("a") as out:
                    out.write(json.dumps(row) + "\n")
                print(row["index"], engine, f"{row['score']:+.4f}", row["cached_score"],
                      row["info"].get("spoon_capacity"), row["info"].get("beads_in_spoon_end"),
                      file=sys.stderr, flush=True)
        return 0
    if args.capacity:
        config = json.loads(args.config)
        for engine in args.engines:
            for row in capacity_rows(args.cache, args.first, args.last, engine,
                                     config if engine == "sapien" else {}, args.indices):
                with args.out.open("a") as out:
                    out.write(json.dumps(row) + "\n")
        return 0
    versions = None
    if args.sapien_version is not None:
        versions = {"pybullet": str(setting_version("pybullet", "scoop")),
                    "sapien": args.sapien_version}
    inputs = disagreeing(args.cache, versions)
    chosen = ([i for i in inputs if i["index"] in set(args.indices)] if args.indices
              else [i for i in inputs if not i["agree"]])
    engines = {name: engine_physics(name) for name in args.engines}
    for item in chosen:
        for name, physics in engines.items():
            recorder = Recorder(physics)
            start = time.process_time()
            result = run_scoop(recorder, np.array(item["context"]), np.array(item["control"]),
                               item["index"])  # type: ignore[arg-type]
            row = {"index": item["index"], "engine": name, "score": result.score,
                   "cached_scores": item["scores"], "info": dict(result.info),
                   "series": recorder.series, "cpu_s": time.process_time() - start}
            with args.out.open("a") as out:
                out.write(json.dumps(row) + "\n")
            info = result.info
            print(item["index"], name, f"{result.score:+.3f}", info.get("spoon_capacity"),
                  info.get("beads_in_spoon_end"), [n for _, n in recorder.series][-8:],
                  file=sys.stderr, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
