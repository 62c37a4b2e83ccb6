"""Experiment 4 — the sampling table (the paper's ``tb:app-sampling`` for Kitchen2D and
``tb:sampling`` for Kitchen3D): FP, T50, N5 and Diversity of rejection / adaptive / diverse.

Reuses :func:`bench.sampling.bench_skill` (the same metrics code as the synthetic table) on
the physical skills: the "true score" of a sample is a real simulated trial. Models: the
shipped ``models/kitchen2d/{pour,scoop}`` and ``models/kitchen3d/{pour,scoop}`` (lse2 GPs);
Kitchen2D push has no shipped model, so one is trained here with ``lse2`` (cached under
``<out>/cache``). β is the paper's relaxed ``Φ⁻¹(0.99 Φ(β*))``. T50 is CPU time of this
thread (the machine is shared); it includes the skill's validity pre-check of accepted
proposals, which dominates on PyBullet.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from bench.paper.common import REPO, Context, live_score, write_json
from bench.sampling import METRICS, SAMPLERS, bench_skill
from ltamp_cli.backends import SkillBackend, load_backend
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.model import LevelSetModel

NAME = "sampling"
LAMBDA = 0.99
SHIPPED = {("box2d", "pour"): "models/kitchen2d/pour", ("box2d", "scoop"): "models/kitchen2d/scoop",
           ("box2d", "push"): "models/kitchen2d/push",
           ("pybullet", "pour"): "models/kitchen3d/pour",
           ("pybullet", "scoop"): "models/kitchen3d/scoop"}
SIZES: dict[str, dict[str, Any]] = {
    # (table, backend, skill, runs)
    # smoke: synthetic skills stand in for both kitchens (plumbing check only).
    "smoke": {"rows": [("2D", "synthetic", "moving2d", 1), ("3D", "synthetic", "skill8d", 1)],
              "train_budget": 15},
    "quick": {"rows": [("2D", "box2d", "pour", 1), ("2D", "box2d", "scoop", 1),
                       ("2D", "box2d", "push", 2), ("3D", "pybullet", "pour", 1)],
              "train_budget": 40},
    "full": {"rows": [("2D", "box2d", "pour", 50), ("2D", "box2d", "scoop", 50),
                      ("2D", "box2d", "push", 50), ("3D", "pybullet", "pour", 50),
                      ("3D", "pybullet", "scoop", 50)],
             "train_budget": 100},
}


class LiveScores:
    """The backend interface ``bench_skill`` needs, with the true score by simulation."""

    def __init__(self, backend: SkillBackend, skill: str) -> None:
        self.backend = backend
        self._score = live_score(backend, skill, seed=4242)

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        return self.backend.sample_context(skill, rng)

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return self.backend.is_valid(skill, context, controls)

    def true_score(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return self._score(np.asarray(context, dtype=float)[None, :], controls)


def model_for(ctx: Context, backend: SkillBackend, name: str, skill: str, budget: int
              ) -> tuple[LevelSetModel, str]:
    """The shipped model of ``(name, skill)`` or one trained with lse2 (cached)."""
    shipped = SHIPPED.get((name, skill))
    if shipped is not None and (REPO / shipped / "model.json").is_file():
        return LevelSetModel.load(str(REPO / shipped)), shipped
    directory = ctx.cache / "models" / f"{name}_{skill}_lse2_{budget}"
    if not (directory / "model.json").is_file():
        config = LearningConfig(strategy="lse2", budget=budget, init=10, seed=0)
        model = learn_online(backend, skill, config, progress=ctx.progress).model
        assert isinstance(model, LevelSetModel)
        model.save(str(directory), backend=name, strategy="lse2")
    return LevelSetModel.load(str(directory)), f"lse2, {budget} trials (trained here)"


def run(ctx: Context) -> dict[str, Any]:
    """Writes ``sampling.json`` and ``sampling.png`` (FP and Diversity per sampler)."""
    started = time.perf_counter()
    sizes = ctx.sizes(SIZES)
    tables: list[dict[str, Any]] = []
    backends: dict[str, SkillBackend] = {}
    try:
        for table_name, name, skill, runs in sizes["rows"]:
            backend = backends.get(name) or backends.setdefault(name, load_backend(name))
            model, source = model_for(ctx, backend, name, skill, sizes["train_budget"])
            t0 = time.perf_counter()
            table = bench_skill(LiveScores(backend, skill), skill, model, runs, LAMBDA,
                                validate=True)
            tables.append({"table": table_name, "backend": name, "skill": skill,
                           "runs": runs, "model": source, "metrics": table,
                           "wall_s": round(time.perf_counter() - t0, 1)})
    finally:
        for backend in backends.values():
            backend.close()
    _plot(tables, ctx)
    payload = {"sizes": {"rows": [list(r) for r in sizes["rows"]],
                         "train_budget": sizes["train_budget"]},
               "lambda": LAMBDA, "samplers": list(SAMPLERS),
               "metrics": [{"key": k, "label": label} for k, label, _ in METRICS],
               "tables": tables, "pngs": [f"{NAME}.png"]}
    write_json(ctx, NAME, payload, started)
    return payload


def _plot(tables: list[dict[str, Any]], ctx: Context) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    labels = [f"{t['table']} {t['skill']}" for t in tables]
    for axis, key, title in ((axes[0], "fp", "FP (%) ↓"), (axes[1], "diversity", "Diversity ↑")):
        for i, sampler in enumerate(SAMPLERS):
            means = [t["metrics"][sampler][key]["mean"] for t in tables]
            stds = [t["metrics"][sampler][key]["std"] for t in tables]
            axis.bar(np.arange(len(tables)) + 0.27 * (i - 1), means, 0.27, yerr=stds,
                     label=sampler, capsize=2)
        axis.set_xticks(range(len(tables)), labels, fontsize=8)
        axis.set_title(title, fontsize=10)
        axis.legend(fontsize=8)
    figure.suptitle(f"Sampling table ({ctx.mode})", fontsize=11)
    figure.tight_layout()
    figure.savefig(ctx.out / f"{NAME}.png", dpi=90)
    plt.close(figure)
