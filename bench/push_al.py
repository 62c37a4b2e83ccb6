"""Kitchen2D push active learning (issue #21): why every learner sits at random's θ* rate.

``python -m bench.push_al run --variant lse --seeds 0-4`` runs one learner variant × seed
jobs on the Box2D push with exactly the standard paper run's protocol (``bench.paper.al2d``,
mode ``standard``: 100 trials, 10 random first, θ* checkpoints every 25 trials, 50 held-out
goals drawn from ``default_rng([2024, 4])``, θ* simulated live with seed ``1000 + seed``,
5,000 candidates) and appends each finished job as one JSON line to
``docs/results/learning/pushal-runs.jsonl`` (``--log``; a rerun skips logged jobs).
``python -m bench.push_al report`` prints the table and paired comparisons (units: seed ×
held-out goal; bootstrap interval of the mean difference, exact sign test) and writes
``docs/results/learning/pushal.json``.

Besides the θ* curve every job records where its training trials went (the diagnosis):

* ``goal_norms`` — ‖goal‖ of every trial (the object starts at the origin; a goal within 2 of
  it succeeds without moving the object, ~8 % of the held-out goals);
* ``moved`` / ``moved_far`` — trials whose push moved the object at all (> 0.05) / by > 2;
* ``circle_still`` — trials with the object left in place and the goal within 0.5 of the
  circle ‖goal‖ = 2, where success is decided by the goal alone;
* ``far_successes`` — training successes with ‖goal‖ > 2.5;
* ``nn_success`` — a score-only baseline on the same trials: for each held-out goal, the
  control of the training success whose goal is nearest, simulated;
* ``theta_star_moved`` — per held-out goal, whether the last checkpoint's θ* moved the object;
* ``replay_bound`` — the share of held-out goals within 2 of where some training push left
  the object (the origin included): what a learner that knew every trial's outcome could
  reach by replaying a training control. The learners see only the score, i.e. one distance
  to that trial's own goal.

``run --skill pour|saturated4d|narrowing5d`` runs a variant on another skill of
``bench.lse2`` (its protocol and held-out contexts; θ* at the budget only) to check that a
change does not hurt elsewhere; ``report`` compares every variant there with ``lse``.

Variants (:data:`VARIANTS`) are :class:`~ltamp_cli.learning.active.LearningConfig` settings;
``nn-*`` variants run the paper's NN loop (:func:`bench.paper.al2d.learn_nn_argmax`). The
``*-hs*`` variants learn from the push's outcome (issue #21, :mod:`ltamp_cli.learning.outcomes`);
their jobs go to ``--log docs/results/learning/pushoutcome-runs.jsonl`` and
``report --out docs/results/learning/pushoutcome.json``, beside copies of the score-only
baselines (``source`` says where each copy comes from). Since outcomes exist the score-only
variants set ``hindsight=False`` explicitly (their runs are unchanged: the golden test of
``tests/learning/test_outcomes.py``).
Times are CPU seconds of this process (the machine is shared).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench.lse2 import _seeds, _wilson
from bench.paper.al2d import ARGMAX_LEARNERS, learn_nn_argmax
from bench.paper.al2d import SIZES as AL2D_SIZES
from bench.paper.common import live_score
from ltamp_cli.backends import load_backend
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.metrics import SkillEvaluator
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.trials.record import is_success

REPO = Path(__file__).resolve().parents[1]
DEFAULT_LOG = REPO / "docs" / "results" / "learning" / "pushal-runs.jsonl"
DEFAULT_JSON = REPO / "docs" / "results" / "learning" / "pushal.json"
SKILL = "push"
STANDARD = AL2D_SIZES["standard"]
SIZES: dict[str, int] = {"budget": STANDARD["budget"], "init": STANDARD["init"],
                         "eval_every": STANDARD["eval_every"],
                         "contexts": STANDARD["contexts"],
                         "candidates": STANDARD["candidates"]}

#: Variant name -> LearningConfig settings (besides budget, init, seed).
VARIANTS: dict[str, dict[str, Any]] = {
    "random": {"strategy": "random", "hindsight": False},
    "lse": {"strategy": "lse", "hindsight": False},
    "lse2": {"strategy": "lse2", "hindsight": False},
    # The reference learner's GP (zi-w/Kitchen2D): zero prior mean, maximum likelihood, every
    # lengthscale bounded to a few percent of its range (push: 0.5 raw units = 0.1-0.16 of
    # the normalised box's half width; one cap for all inputs here).
    "lse-ref": {"strategy": "lse", "mean": "zero", "lengthscale_prior_sd": None,
                "lengthscale_max": 0.16, "hindsight": False},
    # The paper's Algorithm 1 per training context: a drawn goal kept for 15 trials.
    "lse-hold": {"strategy": "lse", "context_repeats": 15, "hindsight": False},
    "lse-hold-ref": {"strategy": "lse", "context_repeats": 15, "mean": "zero",
                     "lengthscale_prior_sd": None, "lengthscale_max": 0.16, "hindsight": False},
    "lse-hold30-ref": {"strategy": "lse", "context_repeats": 30, "mean": "zero",
                       "lengthscale_prior_sd": None, "lengthscale_max": 0.16,
                       "hindsight": False},
    # A looser cap (half the normalised box) with the default fit: no "irrelevant" input.
    "lse-hold-cap1": {"strategy": "lse", "context_repeats": 15, "lengthscale_max": 1.0,
                      "hindsight": False},
    "lse-cap": {"strategy": "lse", "lengthscale_prior_sd": None, "lengthscale_max": 0.16,
                "hindsight": False},
    "lse-zero": {"strategy": "lse", "mean": "zero", "hindsight": False},
    # Issue #21, outcomes: the push reports the object's end position; every trial adds its
    # achieved goal and ``hindsight_goals`` uniform goals with exact scores to the training
    # data (``ltamp_cli.learning.outcomes``; cap ``hindsight_cap`` relabelled points).
    # (-hs variants without "-data": θ* from uniform candidates only, as before issue #21;
    # "-data": θ* also tries the training controls, LevelSetModel.data_candidates)
    "lse-hs": {"strategy": "lse", "hindsight": True, "hindsight_theta_data": False,
               "hindsight_lengthscale_max": None, "hindsight_acquisition": "goal-mean"},
    "lse-hs-data": {"strategy": "lse", "hindsight": True, "hindsight_lengthscale_max": None,
                    "hindsight_acquisition": "goal-mean"},
    "lse-hs-k0": {"strategy": "lse", "hindsight": True, "hindsight_goals": 0,
                  "hindsight_theta_data": False, "hindsight_lengthscale_max": None,
                  "hindsight_acquisition": "goal-mean"},
    # the plain straddle over (control, goal) on the relabelled data (not goal-averaged)
    "lse-hs-joint": {"strategy": "lse", "hindsight": True, "hindsight_acquisition": "joint",
                     "hindsight_theta_data": False, "hindsight_lengthscale_max": None},
    # goal-averaged straddle with every lengthscale capped at 1.0 (half the normalised box):
    # the fit cannot call the controls irrelevant when few pushes moved the object.
    "lse-hs-cap1": {"strategy": "lse", "hindsight": True, "lengthscale_max": 1.0,
                    "hindsight_theta_data": False, "hindsight_acquisition": "goal-mean"},
    # = LearningConfig's defaults for a skill with an outcome (hindsight_lengthscale_max 1.0)
    # before the outcome-cover acquisition (the goal-averaged straddle, named explicitly)
    "lse-hs-cap1-data": {"strategy": "lse", "hindsight": True, "lengthscale_max": 1.0,
                         "hindsight_acquisition": "goal-mean"},
    # the same cap without outcomes: what the cap alone does
    "lse-cap1": {"strategy": "lse", "hindsight": False, "lengthscale_max": 1.0},
    # GP (same relabelling) on uniformly random trials: what the straddle's choice adds.
    "gp-hs": {"strategy": "gp", "hindsight": True, "hindsight_theta_data": False,
              "hindsight_lengthscale_max": None},
    "gp-hs-data": {"strategy": "gp", "hindsight": True, "hindsight_lengthscale_max": None},
    # = LearningConfig's defaults for ``gp`` on a skill with an outcome
    "gp-hs-cap1-data": {"strategy": "gp", "hindsight": True, "lengthscale_max": 1.0},
    # Outcome-model acquisitions (ltamp_cli.learning.outcome_acquisition; issue #21 part 2):
    # the trial chosen by the expected number of goals its outcome resolves / by the summed
    # predictive std of its outcome; otherwise as lse-hs-cap1-data (= today's lse default).
    "lse-ov": {"strategy": "lse", "hindsight": True, "lengthscale_max": 1.0,
               "hindsight_acquisition": "outcome-var"},
    "lse-osd": {"strategy": "lse", "hindsight": True, "lengthscale_max": 1.0,
                "hindsight_acquisition": "outcome-sd"},
    "lse-oc": {"strategy": "lse", "hindsight": True, "lengthscale_max": 1.0,
               "hindsight_acquisition": "outcome-cover"},
    # lse2 on a skill with an outcome (issue #21, third outcome session): the drawn context's
    # valid control chosen by the straddle (lse2's choice before), by outcome-cover (the
    # straddle only breaks ties), and by outcome-cover with half the weight on the drawn goal.
    "lse2-hs-straddle": {"strategy": "lse2", "hindsight": True, "lengthscale_max": 1.0,
                         "hindsight_acquisition": "joint"},
    "lse2-oc": {"strategy": "lse2", "hindsight": True, "lengthscale_max": 1.0,
                "hindsight_acquisition": "outcome-cover"},
    "lse2-oc-w50": {"strategy": "lse2", "hindsight": True, "lengthscale_max": 1.0,
                    "hindsight_acquisition": "outcome-cover", "outcome_own_goal_weight": 0.5},
    # The paper's NN_r / NN_c loop (bench.paper.al2d.learn_nn_argmax), with and without the
    # same relabelled points.
    "nn-r": {"strategy": "nn-r", "hindsight": False},
    "nn-c": {"strategy": "nn-c", "hindsight": False},
    "nn-r-hs": {"strategy": "nn-r", "hindsight": True},
    "nn-c-hs": {"strategy": "nn-c", "hindsight": True},
}
#: The report's paired comparisons (a, b): "a scores higher than b".
COMPARISONS = (("lse-ref", "lse"), ("lse-ref", "random"), ("lse", "random"),
               ("lse-hold", "lse"), ("lse-hold-ref", "lse"), ("lse-hold30-ref", "lse"),
               ("lse-hold-ref", "lse-ref"), ("lse-hold-cap1", "lse"),
               ("lse-cap", "lse"), ("lse-zero", "lse"), ("lse2", "lse"),
               ("lse-hs", "lse"), ("lse-hs", "random"), ("lse-hs-k0", "lse"),
               ("lse-hs", "lse-hs-k0"), ("lse-hs", "gp-hs"), ("gp-hs", "random"),
               ("nn-r-hs", "nn-r"), ("nn-c-hs", "nn-c"), ("lse-hs", "nn-r-hs"),
               ("lse-hs", "nn-c-hs"), ("lse-hs-cap1", "lse"), ("lse-hs-cap1", "lse-cap1"),
               ("lse-hs-cap1", "lse-hs"), ("lse-hs-cap1", "gp-hs"), ("lse-cap1", "lse"),
               ("lse-hs-cap1", "nn-r-hs"), ("lse-hs-cap1", "nn-c-hs"),
               ("lse-hs-cap1", "random"), ("lse-hs-cap1-data", "lse-hs-cap1"),
               ("gp-hs-data", "gp-hs"), ("lse-hs-data", "lse-hs"),
               ("lse-hs-cap1-data", "gp-hs-data"), ("lse-hs-cap1-data", "lse"),
               ("lse-hs-cap1-data", "random"), ("lse-hs-data", "lse"),
               ("gp-hs-data", "random"), ("lse-hs-cap1-data", "gp-hs-cap1-data"),
               ("gp-hs-cap1-data", "gp-hs-data"), ("gp-hs-cap1-data", "random"),
               ("lse-hs-cap1-data", "nn-r-hs"), ("lse-hs-cap1-data", "nn-c-hs"),
               ("lse-hs-cap1-data", "nn-r"), ("lse-hs-cap1-data", "nn-c"))


def _contexts(backend: Any) -> np.ndarray:
    rng = np.random.default_rng([2024, len(SKILL)])  # bench.paper.al2d's held-out goals
    return np.array([backend.sample_context(SKILL, rng)
                     for _ in range(SIZES["contexts"])]).reshape(-1, 2)


def run_job(variant: str, seed: int, budget: int | None = None) -> dict[str, Any]:
    """One variant × seed job: θ* curve, training diagnostics (module doc), CPU seconds."""
    sizes = dict(SIZES)
    if budget is not None:
        sizes["budget"] = budget
    backend = load_backend("box2d")
    try:
        spec = backend.skills()[SKILL]
        contexts = _contexts(backend)

        def is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
            return backend.is_valid(SKILL, context, controls)

        scorer = live_score(backend, SKILL, seed=1000 + seed, key="distance")
        evaluator = SkillEvaluator(spec, None, scorer, contexts, is_valid, seed=seed,
                                   n_candidates=sizes["candidates"])
        config = LearningConfig(budget=sizes["budget"], init=sizes["init"], seed=seed,
                                **VARIANTS[variant])
        cpu0 = time.process_time()
        if config.strategy in ARGMAX_LEARNERS:
            result = learn_nn_argmax(backend, SKILL, config, evaluator, sizes["eval_every"],
                                     sizes["candidates"])
        else:
            result = learn_online(backend, SKILL, config, evaluator=evaluator,
                                  eval_every=sizes["eval_every"])
        cpu = time.process_time() - cpu0
        records = result.records
        # The last checkpoint's θ* trials: did θ* move the object at all? (An unmoved object
        # ends exactly ‖goal‖ from the goal.)
        last = scorer.infos[-len(contexts):]  # type: ignore[attr-defined]
        theta_moved = [abs(float(info["distance"]) - float(np.linalg.norm(c))) > 0.05
                       for info, c in zip(last, contexts, strict=True)]
        goals = np.array([r.context for r in records])
        controls = np.array([r.control for r in records])
        scores = np.array([r.score for r in records])
        finals = np.array([r.outcome if r.outcome is not None
                           else (float(r.info.get("final_x", 0.0)),
                                 float(r.info.get("final_y", 0.0))) for r in records])
        moved = np.linalg.norm(finals, axis=1)
        norms = np.linalg.norm(goals, axis=1)
        success = scores > 0
        # score-only baseline: nearest successful training goal's control
        nearest = np.flatnonzero(success)
        nn = np.array([controls[nearest[np.argmin(np.linalg.norm(goals[nearest] - c, axis=1))]]
                       for c in contexts]) if len(nearest) else None
        nn_scores = (live_score(backend, SKILL, seed=2000 + seed)(contexts, nn)
                     if nn is not None else np.full(len(contexts), -1.0))
        landings = np.vstack([np.zeros((1, 2)), finals])
        covered = (np.linalg.norm(contexts[:, None, :] - landings[None], axis=2) < 2.0).any(1)
    finally:
        backend.close()
    job: dict[str, Any] = {
        "skill": SKILL, "variant": variant, "config": VARIANTS[variant], "seed": seed,
        "sizes": sizes, "cpu_s": round(cpu, 1),
        "training_successes": int(success.sum()),
        "far_successes": int((success & (norms > 2.5)).sum()),
        "moved": int((moved > 0.05).sum()), "moved_far": int((moved > 2.0).sum()),
        "circle_still": int(((moved <= 0.05) & (np.abs(norms - 2.0) < 0.5)).sum()),
        "goal_norms": [round(float(v), 2) for v in norms],
        "scores": [round(float(v), 3) for v in scores],
        "nn_success": [bool(v) for v in nn_scores > 0],
        "replay_bound": [bool(v) for v in covered],
        "theta_star_moved": theta_moved,
        "curve": [{"n_trials": p.n_trials, "success_rate": p.success_rate,
                   "successes": list(p.successes or ())} for p in result.curve]}
    if isinstance(result.model, LevelSetModel):
        gp = result.model.gp
        job["gp"] = {"lengthscales": [round(float(v), 3) for v in gp.lengthscales],
                     "outputscale": round(gp.outputscale, 3), "noise": gp.noise,
                     "mean": round(gp.mean_constant, 3)}
    return job


def run_check(skill: str, variant: str, seed: int) -> dict[str, Any]:
    """One variant × seed job on another skill of ``bench.lse2`` (``pour``: the al2d standard
    protocol; ``saturated4d``/``narrowing5d``: synthetic), θ* at the budget only."""
    from bench.lse2 import SIZES as LSE2_SIZES
    from bench.lse2 import _backend, _evaluator

    sizes = dict(LSE2_SIZES[skill])
    backend = _backend(skill)
    try:
        evaluator = _evaluator(backend, skill, seed)
        config = LearningConfig(budget=sizes["budget"], init=sizes["init"], seed=seed,
                                **VARIANTS[variant])
        cpu0 = time.process_time()
        result = learn_online(backend, skill, config, evaluator=evaluator,
                              eval_every=sizes["budget"])
        cpu = time.process_time() - cpu0
    finally:
        backend.close()
    return {"skill": skill, "variant": variant, "config": VARIANTS[variant], "seed": seed,
            "sizes": sizes, "cpu_s": round(cpu, 1),
            "training_successes": sum(1 for r in result.records if is_success(r)),
            "curve": [{"n_trials": p.n_trials, "success_rate": p.success_rate,
                       "successes": list(p.successes or ())} for p in result.curve]}


def _read_log(path: Path) -> dict[tuple[str, int], dict[str, Any]]:
    jobs: dict[tuple[str, int], dict[str, Any]] = {}
    if path.exists():
        for line in path.read_text().splitlines():
            if line.strip():
                job = json.loads(line)
                jobs[(job.get("skill", SKILL) + "/" + job["variant"], int(job["seed"]))] = job
    return jobs


def report(log: Path, out: Path) -> dict[str, Any]:
    """Per variant: pooled final θ* rate [Wilson 95 %], the training diagnostics, and the
    paired comparisons of :data:`COMPARISONS` over the seeds both variants ran."""
    from bench.paper.stats import paired_comparison

    jobs = _read_log(log)
    rows: dict[str, Any] = {}
    finals: dict[str, dict[int, list[bool]]] = {}
    for variant in VARIANTS:
        mine = {seed: job for (v, seed), job in sorted(jobs.items())
                if v == f"{SKILL}/{variant}" and job["sizes"]["budget"] == SIZES["budget"]}
        if not mine:
            continue
        finals[variant] = {seed: list(job["curve"][-1]["successes"])
                           for seed, job in mine.items()}
        k = sum(sum(v) for v in finals[variant].values())
        n = sum(len(v) for v in finals[variant].values())

        def pooled(key: str, mine: dict[int, dict[str, Any]] = mine) -> dict[str, Any] | None:
            # jobs imported from another log (``source``) may lack the diagnostics
            have = [job[key] for job in mine.values() if key in job]
            if not have:
                return None
            hits, total = sum(sum(v) for v in have), sum(len(v) for v in have)
            return {"rate": round(hits / total, 3), "wilson95": _wilson(hits, total),
                    "seeds": len(have)}

        rows[variant] = {
            "config": VARIANTS[variant], "seeds": sorted(mine),
            "final_per_seed": {str(s): job["curve"][-1]["success_rate"]
                               for s, job in mine.items()},
            "final_pooled": round(k / n, 3), "final_wilson95": _wilson(k, n),
            "nn_success": pooled("nn_success"), "replay_bound": pooled("replay_bound"),
            **{key: {str(s): job[key] for s, job in mine.items() if key in job}
               for key in ("training_successes", "far_successes", "moved", "moved_far",
                           "circle_still", "cpu_s")},
            "theta_star_moved": {str(s): sum(job["theta_star_moved"])
                                 for s, job in mine.items() if "theta_star_moved" in job},
            "sources": sorted({job["source"] for job in mine.values() if "source" in job}),
            "gp": {str(s): job.get("gp") for s, job in mine.items()}}
    comparisons = []
    for a, b in COMPARISONS:
        if a not in finals or b not in finals:
            continue
        seeds = sorted(set(finals[a]) & set(finals[b]))
        if not seeds:
            continue
        c = paired_comparison(a, [float(v) for s in seeds for v in finals[a][s]],
                              b, [float(v) for s in seeds for v in finals[b][s]])
        comparisons.append({"a": a, "b": b, "seeds": seeds, "text": c.describe(),
                            "verdict": c.verdict})
    checks = _check_report(jobs)
    payload = {"experiment": "push active learning (issue #21)", "sizes": SIZES,
               "variants": rows, "comparisons": comparisons, "other_skills": checks}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(payload, indent=1) + "\n")
    print(f"push: final θ* success at {SIZES['budget']} trials (per seed; pooled [Wilson 95 %]); "
          "training: successes / far successes / moved / moved > 2 / still on the circle "
          "(sums over seeds); nn-success, replay bound (pooled)")
    for variant, row in rows.items():
        per_seed = " ".join(f"{v:.2f}" for v in row["final_per_seed"].values())
        low, high = row["final_wilson95"]
        sums = "/".join(str(sum(row[key].values())) if row[key] else "-" for key in
                        ("training_successes", "far_successes", "moved", "moved_far",
                         "circle_still"))
        nn = f"{row['nn_success']['rate']:.3f}" if row["nn_success"] else "-"
        replay = f"{row['replay_bound']['rate']:.3f}" if row["replay_bound"] else "-"
        print(f"{variant:16} {per_seed:30} {row['final_pooled']:.3f} [{low:.3f}, {high:.3f}]  "
              f"{sums:18} nn {nn} replay {replay}")
    for comparison in comparisons:
        print(f"  {comparison['text']}: {comparison['verdict']}")
    for skill, entry in checks.items():
        print(f"{skill}: final θ* " + "; ".join(
            f"{variant} {row['per_seed']} pooled {row['pooled']:.3f} {row['wilson95']}"
            for variant, row in entry["variants"].items()))
        for comparison in entry["comparisons"]:
            print(f"  {comparison['text']}: {comparison['verdict']}")
    return payload


def _check_report(jobs: dict[tuple[str, int], dict[str, Any]]) -> dict[str, Any]:
    """Other skills (``run --skill``): per variant the final θ* per seed, pooled [Wilson], and
    every variant against ``lse`` on the seeds both ran."""
    from bench.paper.stats import paired_comparison

    out: dict[str, Any] = {}
    skills = sorted({key.split("/")[0] for key, _ in jobs} - {SKILL})
    for skill in skills:
        finals: dict[str, dict[int, list[bool]]] = {}
        for (key, seed), job in sorted(jobs.items()):
            if key.startswith(skill + "/"):
                finals.setdefault(job["variant"], {})[seed] = job["curve"][-1]["successes"]
        variants = {}
        for variant, per in finals.items():
            k = sum(sum(v) for v in per.values())
            n = sum(len(v) for v in per.values())
            variants[variant] = {"seeds": sorted(per), "per_seed": [round(sum(v) / len(v), 3)
                                                                    for v in per.values()],
                                 "pooled": round(k / n, 3), "wilson95": _wilson(k, n)}
        comparisons = []
        for variant in finals:
            if variant == "lse" or "lse" not in finals:
                continue
            seeds = sorted(set(finals[variant]) & set(finals["lse"]))
            if not seeds:
                continue
            c = paired_comparison(variant, [float(v) for s in seeds for v in finals[variant][s]],
                                  "lse", [float(v) for s in seeds for v in finals["lse"][s]])
            comparisons.append({"a": variant, "b": "lse", "seeds": seeds, "text": c.describe(),
                                "verdict": c.verdict})
        out[skill] = {"variants": variants, "comparisons": comparisons}
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.push_al",
                                     description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run_p = sub.add_parser("run", help="run variant x seed jobs (skips logged ones)")
    run_p.add_argument("--variant", choices=sorted(VARIANTS), required=True)
    run_p.add_argument("--seeds", default="0-4", help="e.g. 0-4 or 0,2")
    run_p.add_argument("--log", type=Path, default=DEFAULT_LOG)
    run_p.add_argument("--skill", default=SKILL,
                       choices=[SKILL, "pour", "saturated4d", "narrowing5d"],
                       help="another skill of bench.lse2 (θ* at the budget only)")
    rep = sub.add_parser("report", help="table + paired comparisons -> JSON")
    rep.add_argument("--log", type=Path, default=DEFAULT_LOG)
    rep.add_argument("--out", type=Path, default=DEFAULT_JSON)
    args = parser.parse_args(argv)
    if args.command == "report":
        if not args.log.exists():
            print(f"error: no log {args.log}", file=sys.stderr)
            return 2
        report(args.log, args.out)
        return 0
    try:
        seeds = _seeds(args.seeds)
    except ValueError:
        print(f"error: bad --seeds {args.seeds!r} (e.g. 0-4 or 0,2)", file=sys.stderr)
        return 2
    done = _read_log(args.log)
    args.log.parent.mkdir(parents=True, exist_ok=True)
    for seed in seeds:
        if (f"{args.skill}/{args.variant}", seed) in done:
            continue
        job = (run_job(args.variant, seed) if args.skill == SKILL
               else run_check(args.skill, args.variant, seed))
        with args.log.open("a") as handle:
            handle.write(json.dumps(job) + "\n")
        print(f"{args.skill} {args.variant} seed {seed}: "
              f"θ* {job['curve'][-1]['success_rate']:.2f}, "
              f"{job['training_successes']} training successes "
              f"({job.get('far_successes', '-')} far), "
              f"{job['cpu_s']} s CPU", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
