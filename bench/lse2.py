"""GP-LSE2 vs GP-LSE vs Random, paired by seed (issue #21): θ* success over held-out contexts.

``python -m bench.lse2 run --skill pour --learner lse2 --seeds 0-4`` runs learner × seed jobs
and appends each finished job as one JSON line to ``docs/results/learning/lse2-runs.jsonl``
(``--log``); a rerun skips the jobs already logged, so an interrupted run continues.
``python -m bench.lse2 report`` prints a table and writes ``docs/results/learning/lse2.json``;
jobs of ``lse2`` run with the code before the fix (the same command on commit ``c76fd92``'s
``ltamp_cli``) are read from ``lse2-runs-before.jsonl`` and reported as ``lse2-before``.

Skills:

* ``pour`` — the Box2D pour with exactly the standard paper run's protocol
  (``bench.paper.al2d``, mode ``standard``): 100 trials (10 random first), checkpoints every
  25, θ* for 50 held-out contexts drawn from ``default_rng([2024, 4])`` simulated live with
  seed ``1000 + seed``, 5,000 candidates. Its ``lse``/``random`` jobs of the standard run
  (``docs/results/standard/runs/al2d-pour-standard.jsonl``) can be read as the baselines
  (``report --standard-log``), since the protocol is the same.
* ``saturated4d`` — a synthetic skill this project had not used before (defined here): two
  contexts ``a ∈ [0, 1]²``, two controls ``(speed ∈ [0, 5], angle ∈ [−1.5, 1.5])``; in
  normalised control coordinates ``u`` the good set is a disc of radius ``0.26 + 0.1 a₁``
  centred at ``c(a) = (0.6 cos(π a₀), 0.6 sin(π a₀) − 0.2 a₁)``, and the score
  ``g = 3 exp(−‖u − c‖² / (2 r²)) − 1`` saturates at −1 away from it (like the pour's score:
  most failures score the same, so a fresh context's slice is flat). Controls with
  ``u₀ + u₁ > 1.4`` fail the pre-check. Uniform controls succeed ~9 % of the time. θ* is
  scored with the exact score over 100 held-out contexts; 100 trials, checkpoints every 25.
* ``narrowing5d`` — a second synthetic skill (issue #21, defined here, unseen by the GP fit's
  design): two contexts ``a ∈ [0, 1]²``, three controls ``(reach ∈ [0, 2], lift ∈ [−1, 1],
  yaw ∈ [−π, π])``; in normalised control coordinates the good set is a ball centred at
  ``(0.5 cos(2π a₀), 0.5 sin(2π a₀), 0.6 a₁ − 0.3)`` whose radius ``0.55 − 0.3 a₁`` narrows with
  ``a₁``; the score saturates at −1 outside it (same sigmoid as ``saturated4d``). Controls with
  ``u₀ − u₂ > 1.5`` fail the pre-check. Uniform controls succeed ~4 % of the time. Same
  protocol as ``saturated4d``.

``run --prior-sd S`` sets ``LearningConfig.lengthscale_prior_sd`` (``none``: the maximum
marginal likelihood fit before issue #21); each job records it, and a log mixes no settings
(pass a different ``--log``).

Times are CPU seconds of this process (the machine is shared; wall time means little).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.protocol import ParamSpace, SkillBackend, SkillSpec
from ltamp_cli.backends.synthetic import AnalyticSkill, SyntheticBackend, _unit
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.metrics import SkillEvaluator, wilson_interval
from ltamp_cli.trials.record import is_success

REPO = Path(__file__).resolve().parents[1]
DEFAULT_LOG = REPO / "docs" / "results" / "learning" / "lse2-runs.jsonl"
DEFAULT_JSON = REPO / "docs" / "results" / "learning" / "lse2.json"
STANDARD_LOG = REPO / "docs" / "results" / "standard" / "runs" / "al2d-pour-standard.jsonl"
LEARNERS = ("random", "gp", "lse", "lse2")
#: The report's rows: the learners, and ``lse2`` before issue #21's fix (``--before-log``).
ROWS = (*LEARNERS, "lse2-before")
DEFAULT_BEFORE = REPO / "docs" / "results" / "learning" / "lse2-runs-before.jsonl"

#: Per skill: trials, random initial trials, checkpoint spacing, held-out contexts, θ*
#: candidates. ``pour`` is ``bench.paper.al2d``'s standard row.
SIZES: Mapping[str, Mapping[str, int]] = {
    "pour": {"budget": 100, "init": 10, "eval_every": 25, "contexts": 50, "candidates": 5000},
    "saturated4d": {"budget": 100, "init": 10, "eval_every": 25, "contexts": 100,
                    "candidates": 5000},
    "narrowing5d": {"budget": 100, "init": 10, "eval_every": 25, "contexts": 100,
                    "candidates": 5000},
}

SATURATED4D = SkillSpec(
    name="saturated4d",
    context=ParamSpace(("a0", "a1"), (0.0, 0.0), (1.0, 1.0)),
    control=ParamSpace(("speed", "angle"), (0.0, -1.5), (5.0, 1.5)),
    description="2 controls + 2 contexts: a small good disc moving with the context; the "
                "score saturates at -1 elsewhere; one corner fails the pre-check",
)


def saturated4d_score(contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """Score ``(n,)`` of physical ``contexts (n, 2)`` and ``controls (n, 2)`` (see module doc)."""
    u = _unit(controls, SATURATED4D.control)
    a0, a1 = contexts[:, 0], contexts[:, 1]
    center = np.stack([0.6 * np.cos(math.pi * a0), 0.6 * np.sin(math.pi * a0) - 0.2 * a1],
                      axis=1)
    radius = 0.26 + 0.1 * a1
    distance = np.linalg.norm(u - center, axis=1)
    return 2.7 / (1.0 + np.exp(-(radius - distance) / 0.02)) - 1.0


def saturated4d_valid(contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """Pre-check ``(n,)`` bools: the corner ``u₀ + u₁ > 1.4`` is invalid."""
    u = _unit(controls, SATURATED4D.control)
    return u[:, 0] + u[:, 1] <= 1.4


NARROWING5D = SkillSpec(
    name="narrowing5d",
    context=ParamSpace(("a0", "a1"), (0.0, 0.0), (1.0, 1.0)),
    control=ParamSpace(("reach", "lift", "yaw"), (0.0, -1.0, -math.pi), (2.0, 1.0, math.pi)),
    description="3 controls + 2 contexts: a good ball that circles with a0 and narrows with "
                "a1; the score saturates at -1 elsewhere; one edge fails the pre-check",
)


def narrowing5d_score(contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """Score ``(n,)`` of physical ``contexts (n, 2)`` and ``controls (n, 3)`` (module doc)."""
    u = _unit(controls, NARROWING5D.control)
    a0, a1 = contexts[:, 0], contexts[:, 1]
    center = np.stack([0.5 * np.cos(2 * math.pi * a0), 0.5 * np.sin(2 * math.pi * a0),
                       0.6 * a1 - 0.3], axis=1)
    distance = np.linalg.norm(u - center, axis=1)
    return 2.7 / (1.0 + np.exp(-(0.55 - 0.3 * a1 - distance) / 0.02)) - 1.0


def narrowing5d_valid(contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """Pre-check ``(n,)`` bools: the edge ``u₀ − u₂ > 1.5`` is invalid."""
    u = _unit(controls, NARROWING5D.control)
    return u[:, 0] - u[:, 2] <= 1.5


def saturated_backend() -> SyntheticBackend:
    """The synthetic backend with :data:`SATURATED4D` and :data:`NARROWING5D` added
    (noise-free)."""
    backend = SyntheticBackend()
    backend._skills = {**backend._skills,
                       "saturated4d": AnalyticSkill(SATURATED4D, saturated4d_score,
                                                    saturated4d_valid),
                       "narrowing5d": AnalyticSkill(NARROWING5D, narrowing5d_score,
                                                    narrowing5d_valid)}
    return backend


def _backend(skill: str) -> SkillBackend:
    if skill in ("saturated4d", "narrowing5d"):
        return saturated_backend()
    from ltamp_cli.backends import load_backend

    return load_backend("box2d")


def _evaluator(backend: SkillBackend, skill: str, seed: int) -> SkillEvaluator:
    sizes = SIZES[skill]
    spec = backend.skills()[skill]

    def is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return backend.is_valid(skill, context, controls)

    if skill == "pour":
        from bench.paper.common import live_score

        rng = np.random.default_rng([2024, len(skill)])  # al2d's held-out contexts
        contexts = np.array([backend.sample_context(skill, rng)
                             for _ in range(sizes["contexts"])]).reshape(-1, spec.context.dim)
        return SkillEvaluator(spec, None, live_score(backend, skill, seed=1000 + seed),
                              contexts, is_valid, seed=seed, n_candidates=sizes["candidates"])
    assert isinstance(backend, SyntheticBackend)
    rng = np.random.default_rng([2025, 11])
    contexts = np.array([backend.sample_context(skill, rng)
                         for _ in range(sizes["contexts"])]).reshape(-1, spec.context.dim)

    def true_score(c: np.ndarray, u: np.ndarray) -> np.ndarray:
        return backend.true_score(skill, c, u)

    return SkillEvaluator(spec, None, true_score, contexts, is_valid, seed=seed,
                          n_candidates=sizes["candidates"])


def run_job(skill: str, learner: str, seed: int,
            prior_sd: float | None = LearningConfig.lengthscale_prior_sd,
            final_only: bool = False,
            uniform_if_classified: bool = LearningConfig.lse2_uniform_if_classified,
            ) -> dict[str, Any]:
    """One learner × seed job: its θ* curve (only the final point with ``final_only``),
    training successes and CPU seconds. ``uniform_if_classified``:
    ``LearningConfig.lse2_uniform_if_classified`` (``lse2`` only)."""
    sizes = dict(SIZES[skill])
    if final_only:
        sizes["eval_every"] = sizes["budget"]
    backend = _backend(skill)
    try:
        evaluator = _evaluator(backend, skill, seed)
        config = LearningConfig(strategy=learner, budget=sizes["budget"], init=sizes["init"],
                                seed=seed, lengthscale_prior_sd=prior_sd,
                                lse2_uniform_if_classified=uniform_if_classified)
        cpu0 = time.process_time()
        result = learn_online(backend, skill, config, evaluator=evaluator,
                              eval_every=sizes["eval_every"])
        cpu = time.process_time() - cpu0
    finally:
        backend.close()
    return {"skill": skill, "learner": learner, "seed": seed, "sizes": dict(sizes),
            "lengthscale_prior_sd": prior_sd, "cpu_s": round(cpu, 1),
            **({"lse2_uniform_if_classified": uniform_if_classified} if learner == "lse2"
               else {}),
            "training_successes": sum(1 for r in result.records if is_success(r)),
            "curve": [{"n_trials": p.n_trials, "success_rate": p.success_rate,
                       "successes": list(p.successes or ())} for p in result.curve]}


def _same_protocol(sizes: Mapping[str, int] | None, expected: Mapping[str, int]) -> bool:
    """Whether a job's sizes are ``expected``'s, up to ``eval_every`` (``--final-only`` jobs
    skip the intermediate checkpoints; the final θ* evaluation is the same: its candidates
    come from a generator seeded afresh per evaluation)."""
    if sizes is None:
        return False
    return ({k: v for k, v in sizes.items() if k != "eval_every"}
            == {k: v for k, v in expected.items() if k != "eval_every"})


def _read_log(path: Path) -> dict[tuple[str, str, int], dict[str, Any]]:
    jobs: dict[tuple[str, str, int], dict[str, Any]] = {}
    if path.is_file():
        for line in path.read_text().splitlines():
            try:
                entry = json.loads(line)
            except json.JSONDecodeError:
                continue  # a line torn by an interruption
            if _same_protocol(entry.get("sizes"), SIZES[entry["skill"]]):
                jobs[(entry["skill"], entry["learner"], int(entry["seed"]))] = entry
    return jobs


def _standard_jobs(path: Path) -> dict[tuple[str, str, int], dict[str, Any]]:
    """The standard paper run's pour jobs, in this script's job format (same protocol)."""
    jobs: dict[tuple[str, str, int], dict[str, Any]] = {}
    if not path.is_file():
        return jobs
    for line in path.read_text().splitlines():
        try:
            entry = json.loads(line)
        except json.JSONDecodeError:
            continue
        rows = entry.get("rows") or []
        if not rows:
            continue
        learner, seed = rows[0]["learner"], int(rows[0]["seed"])
        jobs[("pour", learner, seed)] = {
            "skill": "pour", "learner": learner, "seed": seed, "source": "standard run",
            "curve": [{"n_trials": r["n_trials"], "success_rate": r["success_rate"],
                       "successes": r["successes"]} for r in rows]}
    return jobs


def _seeds(text: str) -> list[int]:
    if "-" in text:
        low, high = text.split("-", 1)
        return list(range(int(low), int(high) + 1))
    return [int(v) for v in text.split(",")]


def _wilson(k: int, n: int) -> list[float]:
    """Wilson 95 % interval of ``k`` of ``n``, rounded to 3 decimals (for the JSON tables)."""
    return [round(x, 3) for x in wilson_interval(k, n)]


def report(log: Path, out: Path, standard_log: Path | None,
           before_log: Path | None = None) -> dict[str, Any]:
    """Table of final θ* success per skill × learner (pooled Wilson interval over seeds ×
    contexts) and paired comparisons of ``lse2`` against the others (units: seed × context)."""
    from bench.paper.stats import paired_comparison

    jobs = _read_log(log)
    if before_log is not None:
        jobs.update({(skill, "lse2-before", seed): job for (skill, learner, seed), job
                     in _read_log(before_log).items() if learner == "lse2"})
    standard = _standard_jobs(standard_log) if standard_log is not None else {}
    summary: dict[str, Any] = {}
    for skill in SIZES:
        rows: dict[str, Any] = {}
        finals: dict[str, dict[int, list[bool]]] = {}
        for learner in ROWS:
            mine = {seed: job for (s, lr, seed), job in jobs.items()
                    if s == skill and lr == learner}
            theirs = {seed: job for (s, lr, seed), job in standard.items()
                      if s == skill and lr == learner and seed not in mine}
            own = {**theirs, **mine}
            if not own:
                continue
            source = ("this run" if not theirs else "standard run" if not mine
                      else f"std + this ({','.join(map(str, sorted(mine)))})")
            finals[learner] = {seed: list(job["curve"][-1]["successes"])
                               for seed, job in sorted(own.items())}
            k = sum(sum(v) for v in finals[learner].values())
            n = sum(len(v) for v in finals[learner].values())
            rows[learner] = {
                "source": source, "seeds": sorted(own),
                "final_per_seed": {str(seed): job["curve"][-1]["success_rate"]
                                   for seed, job in sorted(own.items())},
                "curve_mean": _curve_mean(list(own.values())),
                "final_pooled": round(k / n, 3), "final_wilson95": _wilson(k, n),
                "training_successes": {str(seed): job.get("training_successes")
                                       for seed, job in sorted(own.items())},
                "cpu_s": {str(seed): job.get("cpu_s") for seed, job in sorted(own.items())}}
        comparisons = []
        if "lse2" in finals:
            for other in ("random", "gp", "lse", "lse2-before"):
                if other not in finals:
                    continue
                seeds = sorted(set(finals["lse2"]) & set(finals[other]))
                if not seeds:
                    continue
                a = [float(v) for seed in seeds for v in finals["lse2"][seed]]
                b = [float(v) for seed in seeds for v in finals[other][seed]]
                c = paired_comparison("lse2", a, other, b)
                comparisons.append({"a": "lse2", "b": other, "seeds": seeds,
                                    "text": c.describe(), "verdict": c.verdict})
        summary[skill] = {"sizes": dict(SIZES[skill]), "learners": rows,
                          "comparisons": comparisons}
    payload = {"experiment": "lse2 (issue #21)", "summary": summary}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(payload, indent=1) + "\n")
    for skill, entry in summary.items():
        print(f"\n{skill}: final θ* success (seeds: per-seed rates; pooled [Wilson 95 %])")
        print(f"{'learner':11} {'source':13} {'per seed':40} pooled")
        for learner, row in entry["learners"].items():
            per_seed = " ".join(f"{v:.2f}" for v in row["final_per_seed"].values())
            low, high = row["final_wilson95"]
            print(f"{learner:11} {row['source']:13} {per_seed:40} {row['final_pooled']:.3f} "
                  f"[{low:.3f}, {high:.3f}]")
        for comparison in entry["comparisons"]:
            print(f"  {comparison['text']}: {comparison['verdict']}")
    return payload


def _curve_mean(jobs: list[dict[str, Any]]) -> dict[str, float]:
    points: dict[int, list[float]] = {}
    for job in jobs:
        for point in job["curve"]:
            points.setdefault(int(point["n_trials"]), []).append(float(point["success_rate"]))
    return {str(n): round(float(np.mean(v)), 3) for n, v in sorted(points.items())}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.lse2",
                                     description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run_p = sub.add_parser("run", help="run learner x seed jobs (skips logged ones)")
    run_p.add_argument("--skill", choices=sorted(SIZES), required=True)
    run_p.add_argument("--learner", choices=LEARNERS, required=True)
    run_p.add_argument("--seeds", default="0-4", help="e.g. 0-4 or 0,2")
    run_p.add_argument("--log", type=Path, default=DEFAULT_LOG)
    run_p.add_argument("--prior-sd", default=str(LearningConfig.lengthscale_prior_sd),
                       help="LearningConfig.lengthscale_prior_sd, or 'none' (maximum "
                            "marginal likelihood)")
    run_p.add_argument("--final-only", action="store_true",
                       help="evaluate θ* only after the last trial (same final number, "
                            "less CPU)")
    run_p.add_argument("--no-uniform-if-classified", action="store_true",
                       help="lse2: keep the largest-ψ control when ψ ≤ 0 for every candidate "
                            "(the choice before LearningConfig.lse2_uniform_if_classified)")
    rep = sub.add_parser("report", help="print the table and write the JSON")
    rep.add_argument("--log", type=Path, default=DEFAULT_LOG)
    rep.add_argument("--out", type=Path, default=DEFAULT_JSON)
    rep.add_argument("--standard-log", type=Path, default=STANDARD_LOG)
    rep.add_argument("--before-log", type=Path, default=DEFAULT_BEFORE,
                     help="jobs of lse2 run with the code before the fix (reported as "
                          "lse2-before)")
    args = parser.parse_args(argv)
    if args.command == "report":
        report(args.log, args.out, args.standard_log, args.before_log)
        return 0
    try:
        seeds = _seeds(args.seeds)
    except ValueError:
        print(f"bench.lse2: bad --seeds {args.seeds!r} (expected e.g. 0-4 or 0,2)",
              file=sys.stderr)
        return 2
    try:
        prior_sd = None if args.prior_sd.lower() == "none" else float(args.prior_sd)
        LearningConfig(lengthscale_prior_sd=prior_sd)
    except ValueError:
        print(f"bench.lse2: bad --prior-sd {args.prior_sd!r} (expected a number > 0 or none)",
              file=sys.stderr)
        return 2
    args.log.parent.mkdir(parents=True, exist_ok=True)
    for seed in seeds:
        if (args.skill, args.learner, seed) in _read_log(args.log):
            print(f"{args.skill} {args.learner} seed {seed}: logged already", flush=True)
            continue
        job = run_job(args.skill, args.learner, seed, prior_sd, args.final_only,
                      not args.no_uniform_if_classified)
        with args.log.open("a") as handle:
            handle.write(json.dumps(job) + "\n")
        print(f"{args.skill} {args.learner} seed {seed}: θ* "
              + " ".join(f"{p['success_rate']:.2f}" for p in job["curve"])
              + f" at {', '.join(str(p['n_trials']) for p in job['curve'])} trials; "
              f"{job['training_successes']} training successes; CPU {job['cpu_s']} s",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
