"""Experiment 4 — the sampling table (the paper's ``tb:app-sampling`` for Kitchen2D and
``tb:sampling`` for Kitchen3D): FP, T50, N5 and Diversity of rejection / adaptive / diverse.

Reuses :func:`bench.sampling.bench_skill` (the same metrics code as the synthetic table) on
the physical skills: the "true score" of a sample is a real simulated trial. Models: the
shipped ``models/kitchen2d/{pour,scoop}`` and ``models/kitchen3d/{pour,scoop}`` (lse2 GPs);
Kitchen2D push has no shipped model, so one is trained here with ``lse2`` (cached under
``<out>/cache``). β is the paper's relaxed ``Φ⁻¹(0.99 Φ(β*))``. T50 is CPU time of this
thread (the machine is shared); it includes the skill's validity pre-check of accepted
proposals, which dominates on PyBullet.

A shipped model trained on part of its skill's context box only is measured there (its
``model.json`` ``training.contexts``): the Kitchen2D push model learned the kitchen's pushes
(goals 3–5 past the block along the table, ``|goal_y| ≤ 0.5``, pushes in line with the block,
``models/README.md``). Its GP found ``goal_y`` irrelevant on that strip (lengthscale 3.7 for a
box 2 wide, normalised), so over the whole goal box ``[-5, 5]²`` it is confidently wrong: for a
goal such as (2.7, -3.9) it proposes the pushes that reach (2.7, 0) with μ/σ ≈ 1.9 and every
sample failed (FP 100 %). The row then also applies the kitchen's section test the model was
trained with, and says so in its ``model`` column.
"""

from __future__ import annotations

import json
import time
from typing import Any

import numpy as np

from bench.paper.common import REPO, Context, JobLog, live_score, write_json
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
    # standard: 2D rows with enough runs for paired tests over runs (~1,900 s CPU).
    "standard": {"rows": [("2D", "box2d", "pour", 10), ("2D", "box2d", "scoop", 10),
                          ("2D", "box2d", "push", 20), ("3D", "pybullet", "pour", 1)],
                 "train_budget": 100},
    "full": {"rows": [("2D", "box2d", "pour", 50), ("2D", "box2d", "scoop", 50),
                      ("2D", "box2d", "push", 50), ("3D", "pybullet", "pour", 50),
                      ("3D", "pybullet", "scoop", 50)],
             "train_budget": 100},
}


class LiveScores:
    """The backend interface ``bench_skill`` needs, with the true score by simulation.

    ``push_strip`` (``{"goal_x_abs": [lo, hi], "goal_y_abs_max": m}``, a push model's training
    contexts): push goals are drawn there and the kitchen's section test joins validity.
    """

    def __init__(self, backend: SkillBackend, skill: str,
                 push_strip: dict[str, Any] | None = None) -> None:
        self.backend = backend
        self.push_strip = push_strip
        self._score = live_score(backend, skill, seed=4242)

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        if self.push_strip is None or skill != "push":
            return self.backend.sample_context(skill, rng)
        side = 1.0 if rng.uniform() < 0.5 else -1.0
        reach = self.push_strip["goal_y_abs_max"]
        return np.array([side * rng.uniform(*self.push_strip["goal_x_abs"]),
                         rng.uniform(-reach, reach)])

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        valid = self.backend.is_valid(skill, context, controls)
        if self.push_strip is None or skill != "push":
            return valid
        from ltamp_cli.backends.box2d.tamp import section_mask

        return valid & section_mask(context, controls)

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


def _push_strip(source: str) -> dict[str, Any] | None:
    """The training contexts of a shipped push model (``source``: its folder), if recorded."""
    path = REPO / source / "model.json"
    if not path.is_file():
        return None
    contexts = json.loads(path.read_text()).get("training", {}).get("contexts")
    if not isinstance(contexts, dict) or not {"goal_x_abs", "goal_y_abs_max"} <= set(contexts):
        return None
    return contexts


#: Estimated CPU seconds of one run of a row (measured in a quick run; PyBullet scoop, not
#: in quick, guessed from its ~2x dearer trials). They only order the parts.
RUN_CPU_S = {("box2d", "pour"): 33.0, ("box2d", "scoop"): 153.0, ("box2d", "push"): 1.2,
             ("pybullet", "pour"): 417.0, ("pybullet", "scoop"): 600.0}


def _part_name(row: tuple[str, str, str, int]) -> str:
    table_name, name, skill, _runs = row
    return f"{table_name}-{name}-{skill}"


def parts(ctx: Context) -> list[tuple[str, float]]:
    """The independent parts of this experiment (one per table row, in the report's order)
    with their estimated CPU seconds: ``python -m bench.paper`` runs them on separate lanes
    and :func:`merge` joins them. A row's numbers do not depend on the other rows (each has
    its own backend, model and true-score seed)."""
    return [(_part_name(row), row[3] * RUN_CPU_S.get((row[1], row[2]), 10.0))
            for row in ctx.sizes(SIZES)["rows"]]


def _part_log(ctx: Context, part: str) -> JobLog:
    """Where part ``part`` is recorded once measured (one log per part: parts run in
    separate processes); a rerun with the same sizes reads it back instead of measuring."""
    return JobLog(ctx, f"{NAME}-{part}", ctx.sizes(SIZES))


def run_part(ctx: Context, part: str) -> dict[str, Any]:
    """Measure one row (``part`` from :func:`parts`), or read it back if an earlier run of
    the same sizes measured it."""
    sizes = ctx.sizes(SIZES)
    rows = {_part_name(r): r for r in sizes["rows"]}
    if part not in rows:
        raise KeyError(f"sampling has no part {part!r} in {ctx.mode} mode "
                       f"(known: {', '.join(rows)})")

    def measure() -> list[dict[str, Any]]:
        table_name, name, skill, runs = rows[part]
        backend = load_backend(name)
        try:
            model, source = model_for(ctx, backend, name, skill, sizes["train_budget"])
            strip = _push_strip(source) if (name, skill) == ("box2d", "push") else None
            if strip is not None:
                source += (f" (goals |x| in {strip['goal_x_abs']}, |y| <= "
                           f"{strip['goal_y_abs_max']}, in-line pushes: where it was trained)")
            t0, cpu0 = time.perf_counter(), time.process_time()
            table = bench_skill(LiveScores(backend, skill, strip), skill, model, runs, LAMBDA,
                                validate=True)
            return [{"table": table_name, "backend": name, "skill": skill, "runs": runs,
                     "model": source, "metrics": table,
                     "wall_s": round(time.perf_counter() - t0, 1),
                     "cpu_s": round(time.process_time() - cpu0, 1)}]
        finally:
            backend.close()

    return _part_log(ctx, part).run(part, measure)[0]


def merge(ctx: Context) -> dict[str, Any]:
    """Join the parts (all must have run in this mode) into ``sampling.json`` and
    ``sampling.png``; the JSON's ``wall_s`` is the parts' summed wall time."""
    sizes = ctx.sizes(SIZES)
    tables: list[dict[str, Any]] = []
    for part, _cost in parts(ctx):
        logged = _part_log(ctx, part).get(part)
        if logged is None:
            raise FileNotFoundError(f"sampling part {part!r} did not finish in {ctx.mode} mode")
        tables.append(logged[0])
    _plot(tables, ctx)
    payload = {"sizes": {"rows": [list(r) for r in sizes["rows"]],
                         "train_budget": sizes["train_budget"]},
               "lambda": LAMBDA, "samplers": list(SAMPLERS),
               "metrics": [{"key": k, "label": label} for k, label, _ in METRICS],
               "tables": tables, "pngs": [f"{NAME}.png"]}
    write_json(ctx, NAME, payload, time.perf_counter() - sum(t["wall_s"] for t in tables))
    return payload


def run(ctx: Context) -> dict[str, Any]:
    """Writes ``sampling.json`` and ``sampling.png`` (FP and Diversity per sampler): every
    part in turn, then :func:`merge`."""
    for part, _cost in parts(ctx):
        run_part(ctx, part)
    return merge(ctx)


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
