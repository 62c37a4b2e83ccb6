"""Experiment 2 — Kitchen3D supervised comparison (the paper's ``fig:nn-rf-gp`` and
``fig:kernel``).

Learners trained on uniformly random trials from the pool (pre-check-valid, as the paper's;
see :mod:`bench.paper.pools`), in a seeded random order per shuffle:
NN_c, NN_r, RF_c, RF_r (scikit-learn) and the GP with the MLP kernel. Top: success rate of the
most confident valid control (1,000 random candidates, as the paper) for held-out contexts,
simulated on PyBullet; bottom: F1 on the held-out test trials. Kernel comparison: the GP's
F1 with the RBF, Matérn-5/2 and MLP kernels under the same protocol.

Difference from the paper: one run per shuffle gives both curves (the paper used 200-trial
runs for the success rate and 400-trial runs for F1).
"""

from __future__ import annotations

import time
from typing import Any

from tqdm import tqdm

from bench.paper.common import (
    CheckpointLog,
    Context,
    JobLog,
    curve_series,
    fit_key,
    live_score,
    plot_panels,
    write_json,
)
from bench.paper.poollearn import (
    CheckpointEvaluator,
    job_sizes,
    pool_curve,
    pooled_skill,
    require_part,
    resume_from,
    skill_parts,
    success_checkpoints,
    theta_validity,
)
from bench.paper.pools import (
    FULL_SKILL_BACKENDS,
    SkillBackends,
    backends_label,
    skill_backend,
)
from ltamp_cli.learning.active import LearningConfig
from ltamp_cli.learning.curves import summarize

NAME = "supervised3d"
LEARNERS = [("nn-c", "matern52"), ("nn-r", "matern52"), ("rf-c", "matern52"),
            ("rf-r", "matern52"), ("gp", "mlp")]
KERNELS = ["rbf", "matern52", "mlp"]
LABELS = {"nn-c": "NNc", "nn-r": "NNr", "rf-c": "RFc", "rf-r": "RFr", "gp": "GP-MLP",
          "gp-rbf": "GP-RBF", "gp-matern52": "GP-Matern52", "gp-mlp": "GP-MLP"}
SIZES: dict[str, dict[str, Any]] = {
    # smoke: the synthetic 8-D skill stands in for the PyBullet skills (plumbing check only).
    "smoke": {"backend": "synthetic", "skills": ["skill8d"], "n_train": 60, "n_test": 40,
              "budget": 30, "eval_every": 15, "seeds": 1, "contexts": 3,
              "success_at": [30], "candidates": 1000},
    # quick: pools of pre-check-valid trials (as the paper's), so 70 of them carry what ~140
    # uniform ones did (pour) or ~300 (scoop; a valid scoop costs ~4 s CPU); 60 per shuffle.
    # One shuffle: each costs ~125 s CPU (mostly the simulated θ*), and the valid-only pools
    # already add ~300 s CPU to the quick run.
    "quick": {"backend": "pybullet", "skills": ["pour", "scoop"], "n_train": 70,
              "n_test": 30, "budget": 60, "eval_every": 20, "seeds": 1, "contexts": 3,
              "success_at": [60], "candidates": 1000},
    # full: the paper's sizes (section 6.1, ltamp-paper.tex lines 1257-1258, 1271). F1: 10
    # shuffles of 400 training and 1,000 test trials ("10 randomly shuffled train and test
    # splits, each consisting of 400 training examples and 1000 test examples"); success
    # rate: the first 5 shuffles only, every 10 trials up to 200, on 45 contexts ("5 randomly
    # shuffled sequences of 200 training examples ... after every 10 examples by sampling 45
    # contexts").
    "full": {"backend": "pybullet", "skill_backends": FULL_SKILL_BACKENDS,
             "skills": ["pour", "scoop"], "n_train": 9000,
             "n_test": 1000, "budget": 400, "eval_every": 10, "seeds": 10, "contexts": 45,
             "success_at": list(range(10, 201, 10)), "success_seeds": 5, "candidates": 1000},
}


def parts(ctx: Context) -> list[tuple[str, float]]:
    """One part per skill (:func:`~bench.paper.poollearn.skill_parts`)."""
    return skill_parts(ctx.sizes(SIZES), len(LEARNERS))


def run_part(ctx: Context, part: str) -> None:
    """Run (or finish) the jobs of skill ``part``; each goes to the job log when done."""
    require_part(NAME, ctx, ctx.sizes(SIZES), part)
    _skill_results(ctx, [part])


def merge(ctx: Context) -> dict[str, Any]:
    """Join every skill's logged jobs into the experiment's JSON and PNGs (a job missing from
    the log is run, so this is :func:`run`)."""
    return run(ctx)


def _skill_results(ctx: Context, names: list[str]) -> dict[str, Any]:
    """The jobs of the skills ``names``: run, or read back from the job log."""
    sizes = ctx.sizes(SIZES)
    backends = SkillBackends(sizes)
    skills: dict[str, Any] = {}
    try:
        for skill in names:
            # Finished jobs: a rerun continues after the last one.
            log = JobLog(ctx, NAME, job_sizes(sizes, skill))
            # Evaluated checkpoints of unfinished jobs: a rerun continues inside a job.
            checkpoints = CheckpointLog(ctx, NAME, job_sizes(sizes, skill))
            backend, pool, spec, contexts, is_valid = pooled_skill(ctx, sizes, backends, skill)

            rows: list[dict[str, Any]] = []
            kernel_rows: list[dict[str, Any]] = []
            jobs = [(s, k, "learner") for s, k in LEARNERS]
            jobs += [("gp", k, "kernel") for k in KERNELS if k != "mlp"]
            for strategy, kernel, kind in tqdm(jobs, desc=f"supervised3d {skill}",
                                               disable=not ctx.progress):
                for seed in range(sizes["seeds"]):
                    key = fit_key(f"{skill}/{strategy}/{kernel}/{kind}/{seed}", strategy)

                    def job(strategy: str = strategy, kernel: str = kernel, kind: str = kind,
                            seed: int = seed, skill: str = skill, pool: Any = pool,
                            spec: Any = spec, contexts: Any = contexts,
                            is_valid: Any = is_valid, backend: Any = backend,
                            key: str = key,
                            checkpoints: CheckpointLog = checkpoints) -> list[dict[str, Any]]:
                        evaluator = CheckpointEvaluator(
                            spec, pool.heldout(),
                            live_score(backend, skill, 500 + seed) if kind == "learner"
                            else None, contexts, theta_validity(is_valid, strategy),
                            success_checkpoints(sizes, seed), seed,
                            sizes["candidates"], **resume_from(checkpoints, key))
                        config = LearningConfig(strategy=strategy, kernel=kernel,
                                                budget=sizes["budget"], seed=seed)
                        return pool_curve(pool, spec, config, sizes["eval_every"],
                                          evaluator)[0]

                    curve = log.run(key, job)
                    for row in curve:
                        if kind == "learner":
                            rows.append({"learner": strategy, **row})
                        if strategy == "gp":
                            kernel_rows.append({"learner": f"gp-{kernel}", **row})
            skills[skill] = {"pool": pool.stats(), "summary": summarize(rows),
                             "kernel_summary": summarize(kernel_rows), "runs": rows,
                             "kernel_runs": kernel_rows}
    finally:
        backends.close()
    return skills


def run(ctx: Context) -> dict[str, Any]:
    """Writes ``supervised3d.json``, ``supervised3d.png`` and ``supervised3d_kernels.png``."""
    started = time.perf_counter()
    sizes = ctx.sizes(SIZES)
    skills = _skill_results(ctx, sizes["skills"])
    learners = [s for s, _ in LEARNERS]
    names = sizes["skills"]
    panels = [{"title": f"{skill}: success rate of θ*", "ylabel": "success rate",
               "series": curve_series(skills[skill]["summary"], "success_rate", learners,
                                      LABELS)} for skill in names]
    panels += [{"title": f"{skill}: held-out F1", "ylabel": "F1",
                "series": curve_series(skills[skill]["summary"], "f1", learners, LABELS)}
               for skill in names]
    plot_panels(panels, ctx.out / f"{NAME}.png",
                title=f"Kitchen3D supervised learners ({backends_label(sizes)}, {ctx.mode})")
    kernels = [f"gp-{k}" for k in KERNELS]
    plot_panels([{"title": f"{skill}: GP kernels, held-out F1", "ylabel": "F1",
                  "series": curve_series(skills[skill]["kernel_summary"], "f1", kernels,
                                         LABELS)} for skill in names],
                ctx.out / f"{NAME}_kernels.png", title=f"Kernel comparison ({ctx.mode})")
    payload = {"sizes": sizes, "backend": sizes["backend"],
               "skill_backends": {s: skill_backend(sizes, s) for s in sizes["skills"]},
               "skills": skills,
               "pngs": [f"{NAME}.png", f"{NAME}_kernels.png"]}
    write_json(ctx, NAME, payload, started)
    return payload
