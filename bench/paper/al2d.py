"""Experiment 1 — Kitchen2D active learning (the paper's appendix figure ``fig:app-model``).

Success rate of the first recommended (most confident) action against the number of trials
for ``random``, ``nn-r``, ``nn-c`` and GP-LSE (``lse``) on the Box2D pour, scoop and push
skills. Learners run live Box2D trials (:func:`ltamp_cli.learning.active.learn_online`);
at every checkpoint each learner's most confident valid control for a fixed set of held-out
contexts is *simulated* and counted a success when its true score is > 0.

NN_c and NN_r follow the paper's protocol (after Kaelbling & Lozano-Pérez 2017): after the
same ``init`` random trials as GP-LSE, each next trial draws a context α from the skill's
context distribution and executes ``θ* = argmax_θ NN(α, θ)`` (the most confident valid control
among ``candidates`` uniform ones); the network is retrained after every trial
(:func:`learn_nn_argmax`). *Random* never trains and draws uniform controls.

Outcomes (issue #21): the push declares an outcome (the object's end position), so with
``LearningConfig``'s defaults (``hindsight=True``) GP-LSE and both networks also learn from
every trial relabelled for other goals (:mod:`ltamp_cli.learning.outcomes`), GP-LSE chooses
its trials with ``LearningConfig.hindsight_acquisition`` (``outcome-cover``: the trial
expected to reach most goals no trial has reached yet,
:mod:`ltamp_cli.learning.outcome_acquisition`; its job key names the acquisition, so jobs of
the earlier goal-averaged straddle are not resumed) and its GP's lengthscales are capped at
1.0; Random is unchanged (it trains nothing). :data:`HINDSIGHT` ``= False`` restores the
score-only learners of the earlier standard runs (pour and scoop declare no outcome: their
jobs are the same either way). Measured in ``docs/results/learning/README.md``, "Outcomes",
and ``docs/results/push/README.md`` (the acquisitions compared).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from tqdm import tqdm

from bench.paper.common import (
    Context,
    JobLog,
    curve_series,
    fit_key,
    live_score,
    plot_panels,
    write_json,
)
from ltamp_cli.backends import load_backend
from ltamp_cli.backends.protocol import SkillBackend
from ltamp_cli.backends.sanity import run_trial_safely
from ltamp_cli.learning.active import LearningConfig, LearningResult, fit_model, learn_online
from ltamp_cli.learning.baselines import RandomModel
from ltamp_cli.learning.curves import summarize
from ltamp_cli.learning.metrics import Evaluation, SkillEvaluator
from ltamp_cli.learning.model import SkillModel
from ltamp_cli.trials.record import TrialRecord

NAME = "al2d"
LEARNERS = ["random", "nn-r", "nn-c", "lse"]
LABELS = {"random": "Random", "nn-r": "NN_r", "nn-c": "NN_c", "lse": "GP-LSE"}
#: Learn from the push's outcomes (module doc); ``False``: scores only, as before issue #21.
HINDSIGHT = True
#: Learners that choose their next trial by their own argmax (the paper's NN_c / NN_r).
ARGMAX_LEARNERS = ("nn-r", "nn-c")
SIZES: dict[str, dict[str, Any]] = {
    "smoke": {"skills": ["push"], "budget": 10, "init": 5, "eval_every": 5, "contexts": 2,
              "seeds": 1, "candidates": 2000},
    # quick: Box2D pour and scoop trials cost ~0.3-0.5 s CPU each, so one seed; push trials
    # cost milliseconds, so push gets 3 seeds x 20 contexts (``per_skill`` overrides).
    "quick": {"skills": ["pour", "scoop", "push"], "budget": 30, "init": 10, "eval_every": 10,
              "contexts": 5, "seeds": 1, "candidates": 5000,
              "per_skill": {"push": {"contexts": 20, "seeds": 3}}},
    # standard (<= 2 h on 2 cores with the other experiments' standard rows): enough units
    # for the paired tests of the report: 5 seeds x 50 held-out contexts, 100 trials.
    # Checkpoints every 25 trials (each costs 50 simulated θ* per job): ~6,000 s CPU.
    "standard": {"skills": ["pour", "scoop", "push"], "budget": 100, "init": 10,
                 "eval_every": 25, "contexts": 50, "seeds": 5, "candidates": 5000},
    # The paper does not state its repetitions for this figure; 5 seeds x 50 contexts.
    "full": {"skills": ["pour", "scoop", "push"], "budget": 100, "init": 10, "eval_every": 10,
             "contexts": 50, "seeds": 5, "candidates": 10_000},
}


#: Estimated CPU seconds of one simulated Box2D trial (training trials and θ* checks alike).
TRIAL_CPU_S = {"pour": 0.5, "scoop": 0.5, "push": 0.01}


def _skill_sizes(sizes: dict[str, Any], skill: str) -> dict[str, Any]:
    return {**sizes, **sizes.get("per_skill", {}).get(skill, {})}


def parts(ctx: Context) -> list[tuple[str, float]]:
    """One part per skill, with its estimated CPU seconds: every learner × seed's training
    trials plus the simulated θ* of each held-out context at each checkpoint."""
    sizes = ctx.sizes(SIZES)
    estimates = []
    for skill in sizes["skills"]:
        own = _skill_sizes(sizes, skill)
        checkpoints = max(1, (own["budget"] - own["init"]) // own["eval_every"] + 1)
        trials = own["budget"] + own["contexts"] * checkpoints
        estimates.append((skill, len(LEARNERS) * own["seeds"] * trials
                          * TRIAL_CPU_S.get(skill, 0.4)))
    return estimates


def _learns_from_outcome(skill: str) -> bool:
    """Whether ``skill`` declares an outcome that this experiment's learners use."""
    backend = load_backend("box2d")
    try:
        return HINDSIGHT and backend.skills()[skill].outcome is not None
    finally:
        backend.close()


def _job_key_sizes(own: dict[str, Any], skill: str) -> dict[str, Any]:
    """What identifies a job in the log: the sizes, plus ``hindsight`` for a skill that
    declares an outcome and learns from it (its jobs differ from the score-only ones of
    earlier runs, which must not be resumed as if they were the same; pour's and scoop's keys
    are unchanged, so their logged jobs stay valid)."""
    return {**own, "hindsight": True} if _learns_from_outcome(skill) else own


def job_key(learner: str, seed: int, learns_from_outcome: bool) -> str:
    """The log key of one job. GP-LSE (and GP-LSE2, should it join :data:`LEARNERS`: since
    issue #21's third outcome session it too chooses by the outcome acquisition) on a skill
    with an outcome chooses its trials with ``LearningConfig.hindsight_acquisition``, so the
    key names it: a job logged under another acquisition (an earlier default) is not resumed
    as if it were this one."""
    if learner in ("lse", "lse2") and learns_from_outcome:
        return fit_key(f"{learner}+{LearningConfig().hindsight_acquisition}/{seed}", learner)
    return fit_key(f"{learner}/{seed}", learner)


def _skill_rows(ctx: Context, skill: str, backend: SkillBackend | None) -> list[dict[str, Any]]:
    """Every learner × seed job of ``skill``: run now (``backend`` given) or read back from
    the job log (``backend=None``: a missing job is an error). Each job is logged when it
    finishes, so an interrupted run continues with the next job."""
    sizes = ctx.sizes(SIZES)
    own = _skill_sizes(sizes, skill)
    log = JobLog(ctx, f"{NAME}-{skill}", _job_key_sizes(own, skill))
    outcome = _learns_from_outcome(skill)
    jobs = [(learner, seed) for learner in LEARNERS for seed in range(own["seeds"])]
    if backend is None:
        missing = [job_key(learner, seed, outcome) for learner, seed in jobs
                   if log.get(job_key(learner, seed, outcome)) is None]
        if missing:
            raise FileNotFoundError(f"al2d {skill}: job {missing[0]} has not run "
                                    f"({len(missing)} missing in {log.path})")
        return [row for learner, seed in jobs
                for row in log.get(job_key(learner, seed, outcome)) or []]
    spec = backend.skills()[skill]
    context_rng = np.random.default_rng([2024, len(skill)])
    contexts = np.array([backend.sample_context(skill, context_rng)
                         for _ in range(own["contexts"])]).reshape(-1, spec.context.dim)

    def is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return backend.is_valid(skill, context, controls)

    def job(learner: str, seed: int) -> list[dict[str, Any]]:
        evaluator = SkillEvaluator(spec, None, live_score(backend, skill, seed=1000 + seed),
                                   contexts, is_valid, seed=seed,
                                   n_candidates=own["candidates"])
        config = LearningConfig(strategy=learner, budget=own["budget"], init=own["init"],
                                seed=seed, hindsight=HINDSIGHT)
        t0 = time.perf_counter()
        if learner in ARGMAX_LEARNERS:
            curve = learn_nn_argmax(backend, skill, config, evaluator, own["eval_every"],
                                    own["candidates"]).curve
        else:
            curve = learn_online(backend, skill, config, evaluator=evaluator,
                                 eval_every=own["eval_every"]).curve
        seconds = time.perf_counter() - t0
        return [{"skill": skill, "learner": learner, "seed": seed, "n_trials": point.n_trials,
                 "success_rate": point.success_rate, "successes": point.successes,
                 "run_s": round(seconds, 2)} for point in curve]

    rows: list[dict[str, Any]] = []
    for learner, seed in tqdm(jobs, desc=f"al2d {skill}", disable=not ctx.progress):
        rows += log.run(job_key(learner, seed, outcome),
                        lambda learner=learner, seed=seed: job(learner, seed))
    return rows


def run_part(ctx: Context, part: str) -> None:
    """Run (or finish) the jobs of skill ``part``; their rows go to the job log."""
    if part not in ctx.sizes(SIZES)["skills"]:
        raise KeyError(f"al2d has no part {part!r} in {ctx.mode} mode")
    backend = load_backend("box2d")
    try:
        _skill_rows(ctx, part, backend)
    finally:
        backend.close()


def merge(ctx: Context) -> dict[str, Any]:
    """Join the logged jobs of every skill into ``al2d.json`` and ``al2d.png``."""
    sizes = ctx.sizes(SIZES)
    rows: list[dict[str, Any]] = []
    skills: dict[str, Any] = {}
    for skill in sizes["skills"]:
        own = _skill_sizes(sizes, skill)
        skill_rows = _skill_rows(ctx, skill, None)
        rows += skill_rows
        skills[skill] = {"summary": summarize(skill_rows), "n_contexts": own["contexts"],
                         "seeds": own["seeds"]}
    panels = [{"title": f"Kitchen2D {skill}", "ylabel": "success rate of θ* (mean ± SE)",
               "series": curve_series(skills[skill]["summary"], "success_rate", LEARNERS,
                                      LABELS)}
              for skill in sizes["skills"]]
    plot_panels(panels, ctx.out / f"{NAME}.png",
                title=f"Kitchen2D active learning ({ctx.mode}; seeds: " + ", ".join(
                    f"{k} {v['seeds']}" for k, v in skills.items()) + ")")
    payload = {"sizes": sizes, "learners": LEARNERS, "skills": skills, "runs": rows,
               "pngs": [f"{NAME}.png"]}
    run_seconds = sum({(r["skill"], r["learner"], r["seed"]): r["run_s"]
                       for r in rows}.values())
    write_json(ctx, NAME, payload, time.perf_counter() - run_seconds)
    return payload


def run(ctx: Context) -> dict[str, Any]:
    """Run the experiment (every part, then :func:`merge`); writes ``al2d.json`` and
    ``al2d.png`` into ``ctx.out``."""
    for part, _cost in parts(ctx):
        run_part(ctx, part)
    return merge(ctx)


def learn_nn_argmax(backend: SkillBackend, skill: str, config: LearningConfig,
                    evaluator: SkillEvaluator | None = None, eval_every: int = 0,
                    n_candidates: int = 5000) -> LearningResult:
    """The paper's NN_c / NN_r loop (``config.strategy`` ``nn-c`` or ``nn-r``), live trials.

    Trials ``0 … init-1``: a context from the skill's distribution and a uniform control, drawn
    in the same order from the same seeded stream as :func:`learn_online`, so GP-LSE and the
    networks start from the same random trials. Every later trial: a fresh context ``α`` and
    ``θ* = argmax NN(α, θ)`` over ``n_candidates`` uniform controls (first valid one by the
    backend's pre-check; classifiers rank by ``p(success)``, regressors by the predicted
    score). The network is refitted on all trials after each one (plus their relabelled
    points when the skill declares an outcome and ``config.hindsight``, the same data
    :func:`learn_online` gives GP-LSE). Returns the last network,
    the trials and the learning curve (``evaluator`` every ``eval_every`` trials and at the
    budget).
    """
    if config.strategy not in ARGMAX_LEARNERS:
        raise ValueError(f"learn_nn_argmax: strategy {config.strategy!r} is not one of "
                         f"{', '.join(ARGMAX_LEARNERS)}")
    spec = backend.skills()[skill]
    rng = np.random.default_rng([config.seed, 0])
    template = RandomModel(spec, 0.0)  # normalisation only
    x: list[np.ndarray] = []
    y: list[float] = []
    records: list[TrialRecord] = []
    model: SkillModel | None = None
    curve: list[Evaluation] = []
    # A skill with a declared outcome: the networks see the relabelled points too, as GP-LSE.
    relabeller = config.relabeller(spec)

    def is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return backend.is_valid(skill, context, controls)

    for index in range(config.budget):
        context = np.asarray(backend.sample_context(skill, rng), dtype=float).reshape(
            spec.context.dim)
        if model is None or index < config.init:
            control = spec.control.sample_uniform(rng, 1)[0]
        else:
            control = model.most_confident_control(context, rng, is_valid, n_candidates)[0]
        seed = int(np.random.SeedSequence([config.seed, index]).generate_state(1)[0]
                   & 0x7FFFFFFF)
        result, _ = run_trial_safely(backend, skill, context, control, seed)
        score = float(result.score) if np.isfinite(result.score) else spec.invalid_score
        records.append(TrialRecord(
            skill=skill, context=tuple(map(float, context)), control=tuple(map(float, control)),
            score=score, valid=bool(result.valid), seed=seed, backend=backend.name,
            index=index, info={"strategy": config.strategy},
            outcome=None if result.outcome is None else tuple(result.outcome)))
        x.append(template.to_unit(context, control)[0])
        y.append(score)
        train_x, train_y = np.array(x), np.array(y)
        if relabeller is not None and result.outcome is not None:
            relabeller.add(context, control, np.asarray(result.outcome))
            extra_x, extra_y = relabeller.arrays()
            train_x, train_y = np.vstack([train_x, extra_x]), np.concatenate([train_y, extra_y])
        # Retrained after every trial, as in the paper (the next argmax needs the new network).
        model = fit_model(spec, config, train_x, train_y)
        n = index + 1
        if evaluator is not None and (
                n == config.budget or (eval_every > 0 and n >= config.init
                                       and n % eval_every == 0)):
            curve.append(evaluator.evaluate(model, n))
    assert model is not None
    return LearningResult(model, records, curve)
