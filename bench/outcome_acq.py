"""Which acquisition for a skill with an outcome (issue #21): push and flick2d, paired.

``python -m bench.outcome_acq run --variant lse-oc --seeds 0-9`` runs one learner variant
(:data:`bench.push_al.VARIANTS`) × seed jobs on the synthetic ``flick2d`` skill (a skill with
an outcome that is not the 2D push: :mod:`ltamp_cli.backends.synthetic`) with the al2d
standard protocol's sizes (100 trials, 10 random first, θ* checkpoints every 25 trials,
50 held-out contexts drawn from ``default_rng([2024, 21])``, θ* among 5,000 candidates
scored by the skill's true score) and appends each job as one JSON line to ``--log``
(a rerun skips logged jobs). The push jobs are run by ``python -m bench.push_al run
--variant V --seeds S --log docs/results/push/outcome-acq-runs.jsonl`` (the al2d standard
push protocol, live Box2D θ*).

``run --variant pool-lse2-oc`` (and the other :data:`POOL_VARIANTS`) runs pool mode on
flick2d instead: the learner picks its 100 trials from :data:`POOL_SIZE` uniformly random
ones (:func:`flick_pool`); jobs go to ``outcome-acq-pool-flick2d-runs.jsonl``. The ``lse2-*``
variants of :data:`bench.push_al.VARIANTS` compare lse2's straddle with the outcome
acquisition (``docs/results/push/README.md``, "lse2 and pool mode").

``python -m bench.outcome_acq report`` reads the three logs and writes
``docs/results/push/outcome-acq.json``: per variant and skill the final θ* success rate
(per seed, pooled with a Wilson interval) and the training diagnostics, and paired
comparisons over seed × held-out context units (bootstrap 95 % interval of the mean
difference, exact sign test; :func:`bench.paper.stats.paired_comparison`) and, since the
contexts of one seed share a model, the same at the seed level (per-seed mean differences,
bootstrap over seeds, sign test over seeds).
Times are CPU seconds of the job's process (the machine is shared).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from bench.lse2 import _seeds, _wilson
from bench.paper.stats import (
    bootstrap_interval,
    paired_comparison,
    sign_flip_test,
    sign_test,
)
from bench.push_al import SIZES, VARIANTS
from ltamp_cli.backends import load_backend
from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.backends.sanity import run_trial_safely
from ltamp_cli.learning.active import LearningConfig, learn_from_pool, learn_online
from ltamp_cli.learning.metrics import SkillEvaluator
from ltamp_cli.trials.record import TrialRecord, is_success

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "docs" / "results" / "push"
FLICK_LOG = RESULTS / "outcome-acq-flick2d-runs.jsonl"
POOL_LOG = RESULTS / "outcome-acq-pool-flick2d-runs.jsonl"
#: Pool mode on flick2d (``run --variant pool-...``): uniformly random trials, seeded
#: ``default_rng([2024, 22])`` (not the held-out contexts' stream), from which the learner
#: picks ``SIZES["budget"]`` without replacement.
POOL_SIZE = 2000
#: Pool-mode variants: LearningConfig settings (besides budget, init, seed). ``joint``: the
#: straddle over the pool candidates (pool mode's choice before); ``outcome-cover``: the
#: outcome acquisition (:func:`ltamp_cli.learning.active._pool_pick`).
POOL_VARIANTS: dict[str, dict[str, Any]] = {
    "pool-lse-straddle": {"strategy": "lse", "hindsight_acquisition": "joint"},
    "pool-lse-oc": {"strategy": "lse", "hindsight_acquisition": "outcome-cover"},
    "pool-lse2-straddle": {"strategy": "lse2", "hindsight_acquisition": "joint"},
    "pool-lse2-oc": {"strategy": "lse2", "hindsight_acquisition": "outcome-cover"},
    "pool-gp": {"strategy": "gp"},
}
PUSH_LOG = RESULTS / "outcome-acq-runs.jsonl"
OUT = RESULTS / "outcome-acq.json"
SKILL = "flick2d"
#: Variant pairs compared (a − b) on each skill.
COMPARISONS = (("lse-oc", "lse-hs-cap1-data"), ("lse-oc", "gp-hs-cap1-data"),
               ("lse-ov", "lse-hs-cap1-data"), ("lse-hs-cap1-data", "gp-hs-cap1-data"),
               ("lse-osd", "lse-hs-cap1-data"), ("lse-oc", "lse-ov"),
               ("lse2-oc", "lse2-hs-straddle"), ("lse2-oc-w50", "lse2-hs-straddle"),
               ("lse2-oc", "lse2-oc-w50"), ("lse2-oc", "lse-oc"),
               ("lse2-oc", "gp-hs-cap1-data"),
               ("pool-lse-oc", "pool-lse-straddle"), ("pool-lse2-oc", "pool-lse2-straddle"),
               ("pool-lse-oc", "pool-gp"), ("pool-lse2-oc", "pool-gp"))


def flick_pool() -> list[TrialRecord]:
    """:data:`POOL_SIZE` uniformly random flick2d trials (context and control uniform over
    their boxes), simulated once; the same pool for every seed and variant."""
    backend = load_backend("synthetic")
    spec = backend.skills()[SKILL]
    rng = np.random.default_rng([2024, 22])
    contexts = spec.context.sample_uniform(rng, POOL_SIZE)
    controls = spec.control.sample_uniform(rng, POOL_SIZE)
    pool = []
    for i, (context, control) in enumerate(zip(contexts, controls, strict=True)):
        result, _ = run_trial_safely(backend, SKILL, context, control, i)
        pool.append(TrialRecord(SKILL, tuple(map(float, context)), tuple(map(float, control)),
                                float(result.score), bool(result.valid), i, backend.name,
                                index=i, outcome=result.outcome))
    return pool


#: How a job learns: (backend, spec, config, evaluator, eval_every) -> learning result.
Learn = Callable[[Any, SkillSpec, LearningConfig, SkillEvaluator, int], Any]


def _flick_job(skill_label: str, variant: str, settings: dict[str, Any], seed: int,
               sizes: dict[str, int], learn: Learn) -> dict[str, Any]:
    """One flick2d job, online or pool mode: the held-out contexts (``sizes["contexts"]``
    from ``default_rng([2024, 21])``), θ* scored by the skill's true score among
    ``sizes["candidates"]``, ``learn`` run with ``settings`` at ``sizes``' budget and init,
    and the job's record (θ* curve, CPU seconds, training diagnostics)."""
    backend = load_backend("synthetic")
    spec = backend.skills()[SKILL]
    rng = np.random.default_rng([2024, 21])
    contexts = spec.context.sample_uniform(rng, sizes["contexts"])

    def score(c: np.ndarray, u: np.ndarray) -> np.ndarray:
        return backend.true_score(SKILL, c, u)

    evaluator = SkillEvaluator(spec, None, score, contexts, None, seed=seed,
                               n_candidates=sizes["candidates"])
    config = LearningConfig(budget=sizes["budget"], init=sizes["init"], seed=seed, **settings)
    cpu0 = time.process_time()
    result = learn(backend, spec, config, evaluator, sizes["eval_every"])
    cpu = time.process_time() - cpu0
    finals = np.array([r.outcome for r in result.records], dtype=float)  # (budget, 2) landings
    moved = np.linalg.norm(finals, axis=1) > 0.05
    # A held-out goal is within reach of replay when some landing (or the origin: no
    # flick) is within the skill's unit tolerance of it.
    landings = np.vstack([np.zeros((1, 2)), finals])
    covered = (np.linalg.norm(contexts[:, None, 1:3] - landings[None], axis=2) < 1.0).any(1)
    return {"skill": skill_label, "variant": variant, "config": settings, "seed": seed,
            "sizes": sizes, "cpu_s": round(cpu, 1),
            "training_successes": int(sum(is_success(r) for r in result.records)),
            "moved": int(moved.sum()), "replay_bound": [bool(v) for v in covered],
            "curve": [{"n_trials": p.n_trials, "success_rate": p.success_rate,
                       "successes": list(p.successes or ())} for p in result.curve]}


def run_pool_job(variant: str, seed: int, pool: list[TrialRecord],
                 sizes: dict[str, int] | None = None) -> dict[str, Any]:
    """One pool-mode flick2d variant × seed job (:data:`POOL_VARIANTS`): θ* curve.
    ``sizes``: default :data:`SIZES` (the al2d standard protocol's)."""

    def learn(backend: Any, spec: SkillSpec, config: LearningConfig,
              evaluator: SkillEvaluator, eval_every: int) -> Any:
        return learn_from_pool(spec, pool, config, evaluator=evaluator, eval_every=eval_every)

    sizes = dict(SIZES) if sizes is None else sizes
    return _flick_job(f"{SKILL}-pool", variant, POOL_VARIANTS[variant], seed,
                      {**sizes, "pool": len(pool)}, learn)


def run_job(variant: str, seed: int, sizes: dict[str, int] | None = None) -> dict[str, Any]:
    """One flick2d variant × seed job: θ* curve and training diagnostics. ``sizes``:
    default :data:`SIZES` (the al2d standard protocol's)."""

    def learn(backend: Any, spec: SkillSpec, config: LearningConfig,
              evaluator: SkillEvaluator, eval_every: int) -> Any:
        return learn_online(backend, SKILL, config, evaluator=evaluator, eval_every=eval_every)

    return _flick_job(SKILL, variant, VARIANTS[variant], seed,
                      dict(SIZES) if sizes is None else sizes, learn)


def _read(path: Path) -> dict[tuple[str, int], dict[str, Any]]:
    jobs: dict[tuple[str, int], dict[str, Any]] = {}
    if path.exists():
        for line in path.read_text().splitlines():
            if line.strip():
                job = json.loads(line)
                jobs[(job["variant"], int(job["seed"]))] = job
    return jobs


def _skill_report(jobs: dict[tuple[str, int], dict[str, Any]]) -> dict[str, Any]:
    finals: dict[str, dict[int, list[bool]]] = {}
    for (variant, seed), job in sorted(jobs.items()):
        finals.setdefault(variant, {})[seed] = list(job["curve"][-1]["successes"])
    rows = {}
    for variant, per_seed in finals.items():
        k = sum(sum(v) for v in per_seed.values())
        n = sum(len(v) for v in per_seed.values())
        mine = {s: jobs[(variant, s)] for s in per_seed}
        replay = [v for job in mine.values() for v in job.get("replay_bound", [])]
        rows[variant] = {
            "seeds": sorted(per_seed),
            "final_per_seed": {str(s): round(float(np.mean(v)), 3) for s, v in per_seed.items()},
            "final_pooled": round(k / n, 3), "final_wilson95": _wilson(k, n),
            "moved": {str(s): job.get("moved") for s, job in mine.items()},
            "replay_bound": round(float(np.mean(replay)), 3) if replay else None,
            "cpu_s": {str(s): job.get("cpu_s") for s, job in mine.items()}}
    comparisons = []
    for a, b in COMPARISONS:
        if a not in finals or b not in finals:
            continue
        seeds = sorted(set(finals[a]) & set(finals[b]))
        c = paired_comparison(a, [float(v) for s in seeds for v in finals[a][s]],
                              b, [float(v) for s in seeds for v in finals[b][s]])
        per_seed = np.array([np.mean(finals[a][s]) - np.mean(finals[b][s]) for s in seeds])
        low, high = bootstrap_interval(per_seed)
        p_seeds, wins, losses = sign_test(per_seed)
        comparisons.append({"a": a, "b": b, "seeds": seeds, "text": c.describe(),
                            "verdict": c.verdict, "difference": c.difference,
                            "interval": [c.low, c.high], "p_value": c.p_value,
                            "seed_level": {"differences": [round(float(v), 3) for v in per_seed],
                                           "interval": [round(low, 4), round(high, 4)],
                                           "wins": wins, "losses": losses,
                                           "sign_p": p_seeds,
                                           "sign_flip_p": sign_flip_test(per_seed)}})
    return {"variants": rows, "comparisons": comparisons}


def report(push_log: Path, flick_log: Path, out: Path,
           pool_log: Path = POOL_LOG) -> dict[str, Any]:
    """Tables and paired comparisons of both skills; written to ``out`` and printed."""
    payload: dict[str, Any] = {
        "experiment": "acquisition for a skill with an outcome (issue #21)", "sizes": SIZES,
        "logs": {"push": str(push_log.relative_to(REPO)) if push_log.is_relative_to(REPO)
                 else str(push_log),
                 "flick2d": str(flick_log.relative_to(REPO)) if flick_log.is_relative_to(REPO)
                 else str(flick_log)},
        "skills": {"push": _skill_report(_read(push_log)),
                   "flick2d": _skill_report(_read(flick_log)),
                   "flick2d-pool": _skill_report(_read(pool_log))}}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(payload, indent=1) + "\n")
    for skill, part in payload["skills"].items():
        print(f"{skill}: final θ* success at {SIZES['budget']} trials, per seed; pooled "
              "[Wilson 95 %]; trials that moved the object (sum); replay bound")
        for variant, row in part["variants"].items():
            per_seed = " ".join(f"{v:.2f}" for v in row["final_per_seed"].values())
            low, high = row["final_wilson95"]
            moved = sum(v for v in row["moved"].values() if v is not None)
            print(f"  {variant:17} {per_seed:50} {row['final_pooled']:.3f} "
                  f"[{low:.3f}, {high:.3f}]  moved {moved:4d}  replay {row['replay_bound']}")
        for comparison in part["comparisons"]:
            level = comparison["seed_level"]
            print(f"    {comparison['text']}: {comparison['verdict']}\n"
                  f"      seed level (bootstrap over {len(comparison['seeds'])} seeds): "
                  f"[{level['interval'][0]:+.3f}, {level['interval'][1]:+.3f}], "
                  f"{level['wins']} wins / {level['losses']} losses, sign p = "
                  f"{level['sign_p']:.3g}, exact sign-flip p = {level['sign_flip_p']:.3g}")
    return payload


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.outcome_acq",
                                     description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run_p = sub.add_parser("run", help="run flick2d variant x seed jobs (skips logged ones)")
    run_p.add_argument("--variant", choices=sorted({*VARIANTS, *POOL_VARIANTS}),
                       required=True)
    run_p.add_argument("--seeds", default="0-9", help="e.g. 0-9 or 0,2")
    run_p.add_argument("--log", type=Path, default=None,
                       help="default: the flick2d log (pool-* variants: the pool log)")
    rep = sub.add_parser("report", help="tables + paired comparisons -> JSON")
    rep.add_argument("--push-log", type=Path, default=PUSH_LOG)
    rep.add_argument("--flick-log", type=Path, default=FLICK_LOG)
    rep.add_argument("--pool-log", type=Path, default=POOL_LOG)
    rep.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    if args.command == "report":
        report(args.push_log.resolve(), args.flick_log.resolve(), args.out,
               args.pool_log.resolve())
        return 0
    try:
        seeds = _seeds(args.seeds)
    except ValueError:
        print(f"error: bad --seeds {args.seeds!r} (e.g. 0-9 or 0,2)", file=sys.stderr)
        return 2
    pooled = args.variant in POOL_VARIANTS
    if args.log is None:
        args.log = POOL_LOG if pooled else FLICK_LOG
    if not pooled and VARIANTS[args.variant]["strategy"] not in ("lse", "lse2", "gp", "random"):
        print(f"error: variant {args.variant!r} is not a GP/random learner", file=sys.stderr)
        return 2
    done = _read(args.log)
    args.log.parent.mkdir(parents=True, exist_ok=True)
    pool = flick_pool() if pooled else []
    for seed in seeds:
        if (args.variant, seed) in done:
            continue
        job = run_pool_job(args.variant, seed, pool) if pooled else run_job(args.variant, seed)
        with args.log.open("a") as handle:
            handle.write(json.dumps(job) + "\n")
        print(f"{SKILL} {args.variant} seed {seed}: θ* {job['curve'][-1]['success_rate']:.2f}, "
              f"moved {job['moved']}, {job['cpu_s']} s CPU", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
