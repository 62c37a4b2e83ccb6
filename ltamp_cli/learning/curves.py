"""Learning-curve tables and PNG plots (F1 and success rate against the number of trials)."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

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
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path
