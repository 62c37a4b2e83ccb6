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
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from tqdm import tqdm

from bench.paper.common import Context, curve_series, live_score, plot_panels, write_json
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
    # The paper does not state its repetitions for this figure; 5 seeds x 50 contexts.
    "full": {"skills": ["pour", "scoop", "push"], "budget": 100, "init": 10, "eval_every": 10,
             "contexts": 50, "seeds": 5, "candidates": 10_000},
}


def run(ctx: Context) -> dict[str, Any]:
    """Run the experiment; writes ``al2d.json`` and ``al2d.png`` into ``ctx.out``."""
    started = time.perf_counter()
    sizes = ctx.sizes(SIZES)
    backend = load_backend("box2d")
    rows: list[dict[str, Any]] = []
    skills: dict[str, Any] = {}
    try:
        for skill in sizes["skills"]:
            own = {**sizes, **sizes.get("per_skill", {}).get(skill, {})}
            spec = backend.skills()[skill]
            context_rng = np.random.default_rng([2024, len(skill)])
            contexts = np.array([backend.sample_context(skill, context_rng)
                                 for _ in range(own["contexts"])]).reshape(-1, spec.context.dim)

            def is_valid(context: np.ndarray, controls: np.ndarray, skill: str = skill
                         ) -> np.ndarray:
                return backend.is_valid(skill, context, controls)

            jobs = [(learner, seed) for learner in LEARNERS for seed in range(own["seeds"])]
            for learner, seed in tqdm(jobs, desc=f"al2d {skill}", disable=not ctx.progress):
                evaluator = SkillEvaluator(
                    spec, None, live_score(backend, skill, seed=1000 + seed), contexts,
                    is_valid, seed=seed, n_candidates=sizes["candidates"])
                config = LearningConfig(strategy=learner, budget=sizes["budget"],
                                        init=sizes["init"], seed=seed)
                t0 = time.perf_counter()
                if learner in ARGMAX_LEARNERS:
                    curve = learn_nn_argmax(backend, skill, config, evaluator,
                                            sizes["eval_every"], sizes["candidates"]).curve
                else:
                    curve = learn_online(backend, skill, config, evaluator=evaluator,
                                         eval_every=sizes["eval_every"]).curve
                seconds = time.perf_counter() - t0
                for point in curve:
                    rows.append({"skill": skill, "learner": learner, "seed": seed,
                                 "n_trials": point.n_trials, "success_rate": point.success_rate,
                                 "run_s": round(seconds, 2)})
            skill_rows = [r for r in rows if r["skill"] == skill]
            skills[skill] = {"summary": summarize(skill_rows),
                             "n_contexts": len(contexts), "seeds": own["seeds"]}
    finally:
        backend.close()
    panels = [{"title": f"Kitchen2D {skill}", "ylabel": "success rate of θ*",
               "series": curve_series(skills[skill]["summary"], "success_rate", LEARNERS,
                                      LABELS)}
              for skill in sizes["skills"]]
    plot_panels(panels, ctx.out / f"{NAME}.png",
                title=f"Kitchen2D active learning ({ctx.mode}; seeds: " + ", ".join(
                    f"{k} {v['seeds']}" for k, v in skills.items()) + ")")
    payload = {"sizes": sizes, "learners": LEARNERS, "skills": skills, "runs": rows,
               "pngs": [f"{NAME}.png"]}
    write_json(ctx, NAME, payload, started)
    return payload


def learn_nn_argmax(backend: SkillBackend, skill: str, config: LearningConfig,
                    evaluator: SkillEvaluator | None = None, eval_every: int = 0,
                    n_candidates: int = 5000) -> LearningResult:
    """The paper's NN_c / NN_r loop (``config.strategy`` ``nn-c`` or ``nn-r``), live trials.

    Trials ``0 … init-1``: a context from the skill's distribution and a uniform control, drawn
    in the same order from the same seeded stream as :func:`learn_online`, so GP-LSE and the
    networks start from the same random trials. Every later trial: a fresh context ``α`` and
    ``θ* = argmax NN(α, θ)`` over ``n_candidates`` uniform controls (first valid one by the
    backend's pre-check; classifiers rank by ``p(success)``, regressors by the predicted
    score). The network is refitted on all trials after each one. Returns the last network,
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
            index=index, info={"strategy": config.strategy}))
        x.append(template.to_unit(context, control)[0])
        y.append(score)
        # Retrained after every trial, as in the paper (the next argmax needs the new network).
        model = fit_model(spec, config, np.array(x), np.array(y))
        n = index + 1
        if evaluator is not None and (
                n == config.budget or (eval_every > 0 and n >= config.init
                                       and n % eval_every == 0)):
            curve.append(evaluator.evaluate(model, n))
    assert model is not None
    return LearningResult(model, records, curve)
