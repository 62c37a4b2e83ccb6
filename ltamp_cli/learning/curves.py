"""Learning-curve tables and PNG plots (F1 and success rate against the number of trials)."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.atomic_file import replaced_atomically

METRICS = ("f1", "success_rate")
LABELS = {"f1": "held-out F1", "success_rate": "success rate of θ*"}


def summarize(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Mean and standard error per ``(learner, n_trials)`` over rows (one per seed).

    Each row has ``learner``, ``n_trials`` and optionally ``f1``/``success_rate`` (``None``
    when not measured).
    """
    groups: dict[tuple[str, int], dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for row in rows:
        key = (str(row["learner"]), int(row["n_trials"]))
        for metric in METRICS:
            if row.get(metric) is not None:
                groups[key][metric].append(float(row[metric]))
    summary = []
    for (learner, n), values in sorted(groups.items()):
        entry: dict[str, Any] = {"learner": learner, "n_trials": n}
        for metric in METRICS:
            samples = np.asarray(values.get(metric, []), dtype=float)
            entry[f"{metric}_mean"] = float(samples.mean()) if len(samples) else None
            entry[f"{metric}_stderr"] = (
                float(samples.std(ddof=1) / np.sqrt(len(samples))) if len(samples) > 1 else 0.0
            )
            entry[f"{metric}_count"] = len(samples)
        summary.append(entry)
    return summary


def plot_curves(rows: Iterable[Mapping[str, Any]], path: str | Path, title: str = "") -> Path:
    """Write a PNG with one panel per measured metric (mean ± standard error per learner)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summary = summarize(rows)
    metrics = [m for m in METRICS if any(e[f"{m}_mean"] is not None for e in summary)]
    if not metrics:
        raise ValueError("no F1 or success-rate values to plot")
    figure, axes = plt.subplots(1, len(metrics), figsize=(5.5 * len(metrics), 4), squeeze=False)
    learners = sorted({e["learner"] for e in summary})
    for axis, metric in zip(axes[0], metrics, strict=True):
        for learner in learners:
            points = [
                e for e in summary if e["learner"] == learner and e[f"{metric}_mean"] is not None
            ]
            if not points:
                continue
            n = np.array([e["n_trials"] for e in points])
            mean = np.array([e[f"{metric}_mean"] for e in points])
            err = np.array([e[f"{metric}_stderr"] for e in points])
            axis.plot(n, mean, marker="o", markersize=3, label=learner)
            axis.fill_between(n, mean - err, mean + err, alpha=0.2)
        axis.set_xlabel("number of trials")
        axis.set_ylabel(LABELS[metric])
        axis.set_ylim(-0.02, 1.02)
        axis.grid(alpha=0.3)
        axis.legend(fontsize=8)
    if title:
        figure.suptitle(title)
    figure.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with replaced_atomically(path) as temporary:
        figure.savefig(temporary, dpi=100)
    plt.close(figure)
    return path


def rows_from_model_metadata(metadata: Mapping[str, Any], label: str | None = None
                             ) -> list[dict[str, Any]]:
    """Learning-curve rows saved in a model directory's ``model.json`` (``curve`` entries).

    Each row gets ``learner`` = ``label`` or the model's strategy. Raises ``ValueError`` when
    the model was trained without a curve (``ltamp train`` without ``--eval-every``/``--curve``).
    """
    curve = metadata.get("curve") or []
    if not isinstance(curve, list) or not curve:
        raise ValueError("no learning curve saved: train with --eval-every K or --curve FILE")
    name = label or str(metadata.get("strategy") or metadata.get("kind") or "model")
    rows = []
    for point in curve:
        if not isinstance(point, Mapping) or "n_trials" not in point:
            raise ValueError("malformed learning-curve entry in model.json")
        rows.append({**point, "learner": name})
    return rows


def train_curves(
    backend: Any,
    skill: str,
    strategies: list[str],
    *,
    budget: int,
    seeds: int,
    eval_every: int,
    init: int = 10,
    kernel: str = "matern52",
    seed: int = 0,
    n_contexts: int = 30,
    progress: bool = False,
) -> list[dict[str, Any]]:
    """Train every strategy ``seeds`` times on a backend with a true score; curve rows.

    One held-out evaluator (seeded by ``seed``) serves every strategy and seed, so the curves
    differ only by the learners. Rows: ``learner, seed, n_trials, f1, success_rate, run_s``.
    """
    import time

    from ltamp_cli.learning.active import LearningConfig, learn_online
    from ltamp_cli.learning.metrics import SkillEvaluator

    evaluator = SkillEvaluator.synthetic(backend, skill, n_test=2000, n_contexts=n_contexts,
                                         seed=seed + 12345)
    rows: list[dict[str, Any]] = []
    for strategy in strategies:
        for offset in range(seeds):
            config = LearningConfig(strategy=strategy, budget=budget, init=init,
                                    seed=seed + offset, kernel=kernel)
            start = time.perf_counter()
            result = learn_online(backend, skill, config, evaluator=evaluator,
                                  eval_every=eval_every, progress=progress)
            seconds = time.perf_counter() - start
            rows.extend(
                {"skill": skill, "learner": strategy, "seed": seed + offset,
                 "n_trials": point.n_trials, "f1": point.f1,
                 "success_rate": point.success_rate, "run_s": seconds}
                for point in result.curve
            )
    return rows


def _finite(value: Any) -> Any:
    """``value`` with NaN/inf floats replaced by ``None`` (strict JSON)."""
    if isinstance(value, float):
        return value if np.isfinite(value) else None
    if isinstance(value, Mapping):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


def write_curves(rows: list[dict[str, Any]], png: str | Path, title: str = ""
                 ) -> tuple[Path, Path]:
    """The PNG (every learner on one figure) and ``<png stem>.json`` beside it.

    The JSON holds ``learners`` (in plotting order), the per-``(learner, n_trials)``
    ``summary`` and the raw ``rows``.
    """
    import json

    png = plot_curves(rows, png, title=title)
    summary = summarize(rows)
    data = {
        "title": title,
        "learners": sorted({e["learner"] for e in summary}),
        "summary": summary,
        "rows": rows,
    }
    path = png.with_suffix(".json")
    with replaced_atomically(path) as temporary:
        temporary.write_text(json.dumps(_finite(data), indent=2, allow_nan=False) + "\n")
    return png, path
