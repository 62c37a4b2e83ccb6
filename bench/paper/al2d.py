"""Experiment 1 — Kitchen2D active learning (the paper's appendix figure ``fig:app-model``).

Success rate of the first recommended (most confident) action against the number of trials
for ``random``, ``nn-r``, ``nn-c`` and GP-LSE (``lse``) on the Box2D pour, scoop and push
skills. Learners run live Box2D trials (:func:`ltamp_cli.learning.active.learn_online`);
at every checkpoint each learner's most confident valid control for a fixed set of held-out
contexts is *simulated* and counted a success when its true score is > 0.

Difference from the paper: our NN baselines are trained on uniformly random trials (the
paper's NN_c/NN_r chose their own next trial by their argmax); noted in the report.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from tqdm import tqdm

from bench.paper.common import Context, curve_series, live_score, plot_panels, write_json
from ltamp_cli.backends import load_backend
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.curves import summarize
from ltamp_cli.learning.metrics import SkillEvaluator

NAME = "al2d"
LEARNERS = ["random", "nn-r", "nn-c", "lse"]
LABELS = {"random": "Random", "nn-r": "NN_r", "nn-c": "NN_c", "lse": "GP-LSE"}
SIZES: dict[str, dict[str, Any]] = {
    "smoke": {"skills": ["push"], "budget": 10, "init": 5, "eval_every": 5, "contexts": 2,
              "seeds": 1, "candidates": 2000},
    "quick": {"skills": ["pour", "scoop", "push"], "budget": 30, "init": 10, "eval_every": 10,
              "contexts": 5, "seeds": 1, "candidates": 5000},
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
            spec = backend.skills()[skill]
            context_rng = np.random.default_rng([2024, len(skill)])
            contexts = np.array([backend.sample_context(skill, context_rng)
                                 for _ in range(sizes["contexts"])]).reshape(-1, spec.context.dim)

            def is_valid(context: np.ndarray, controls: np.ndarray, skill: str = skill
                         ) -> np.ndarray:
                return backend.is_valid(skill, context, controls)

            jobs = [(learner, seed) for learner in LEARNERS for seed in range(sizes["seeds"])]
            for learner, seed in tqdm(jobs, desc=f"al2d {skill}", disable=not ctx.progress):
                evaluator = SkillEvaluator(
                    spec, None, live_score(backend, skill, seed=1000 + seed), contexts,
                    is_valid, seed=seed, n_candidates=sizes["candidates"])
                config = LearningConfig(strategy=learner, budget=sizes["budget"],
                                        init=sizes["init"], seed=seed)
                t0 = time.perf_counter()
                result = learn_online(backend, skill, config, evaluator=evaluator,
                                      eval_every=sizes["eval_every"])
                seconds = time.perf_counter() - t0
                for point in result.curve:
                    rows.append({"skill": skill, "learner": learner, "seed": seed,
                                 "n_trials": point.n_trials, "success_rate": point.success_rate,
                                 "run_s": round(seconds, 2)})
            skill_rows = [r for r in rows if r["skill"] == skill]
            skills[skill] = {"summary": summarize(skill_rows),
                             "n_contexts": len(contexts)}
    finally:
        backend.close()
    panels = [{"title": f"Kitchen2D {skill}", "ylabel": "success rate of θ*",
               "series": curve_series(skills[skill]["summary"], "success_rate", LEARNERS,
                                      LABELS)}
              for skill in sizes["skills"]]
    plot_panels(panels, ctx.out / f"{NAME}.png",
                title=f"Kitchen2D active learning ({ctx.mode}, {sizes['seeds']} seed(s))")
    payload = {"sizes": sizes, "learners": LEARNERS, "skills": skills, "runs": rows,
               "pngs": [f"{NAME}.png"]}
    write_json(ctx, NAME, payload, started)
    return payload
