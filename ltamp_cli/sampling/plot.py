"""Picture of samples over a model's predicted super-level set (1-D or 2-D controls).

1-D: posterior mean ± 2σ, the training points of this context (if any lie on it), the set
``Â_α`` as black segments and the samples as ticks. 2-D: ``μ/σ`` as a colour map with the set
outlined (level ``β``) and the samples as dots. Written as PNG with the Agg backend.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ltamp_cli.atomic_file import replaced_atomically
from ltamp_cli.sampling.superlevel import SuperLevelSet

GRID_1D = 600
GRID_2D = 160


def plot_samples(superlevel: SuperLevelSet, samples: np.ndarray, path: str | Path,
                 title: str = "") -> Path:
    """Draw ``samples (k, dθ)`` (physical) over ``superlevel``; ``dθ`` must be 1 or 2."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    dim = superlevel.dim
    if dim not in (1, 2):
        raise ValueError(f"plots need 1 or 2 controls, this skill has {dim}")
    names = superlevel.model.spec.control.names
    samples = np.asarray(samples, dtype=float).reshape(-1, dim)
    figure, axes = plt.subplots(figsize=(6.4, 4.8))
    if dim == 1:
        u = np.linspace(-1.0, 1.0, GRID_1D)[:, None]
        theta = superlevel.to_physical(u)[:, 0]
        mean, std = superlevel.posterior.predict(u)
        axes.fill_between(theta, mean - 2 * std, mean + 2 * std, color="pink", alpha=0.6,
                          label="μ ± 2σ")
        axes.plot(theta, mean, color="red", label="μ")
        axes.axhline(0.0, color="grey", linewidth=0.8)
        inside = np.where(superlevel.contains(u), 0.0, np.nan)
        axes.plot(theta, inside, color="black", linewidth=4, label=f"Â (β = {superlevel.beta:.2f})")
        axes.plot(samples[:, 0], np.zeros(len(samples)), "|", color="tab:blue", markersize=14,
                  label="samples")
        axes.set_xlabel(names[0])
        axes.set_ylabel("score")
    else:
        grid = np.linspace(-1.0, 1.0, GRID_2D)
        uu = np.stack(np.meshgrid(grid, grid), axis=-1).reshape(-1, 2)
        ratio = superlevel.ratio(uu).reshape(GRID_2D, GRID_2D)
        physical = superlevel.to_physical(uu)
        xs = physical[:, 0].reshape(GRID_2D, GRID_2D)
        ys = physical[:, 1].reshape(GRID_2D, GRID_2D)
        limit = float(np.nanpercentile(np.abs(ratio), 99)) or 1.0
        mesh = axes.pcolormesh(xs, ys, ratio, cmap="RdBu", vmin=-limit, vmax=limit,
                               shading="auto")
        figure.colorbar(mesh, ax=axes, label="μ/σ")
        axes.contour(xs, ys, ratio, levels=[superlevel.beta], colors="black", linewidths=2)
        axes.scatter(samples[:, 0], samples[:, 1], s=14, color="gold", edgecolors="black",
                     linewidths=0.5, label="samples", zorder=3)
        axes.set_xlabel(names[0])
        axes.set_ylabel(names[1])
    axes.legend(loc="best", fontsize=8)
    axes.set_title(title or f"{superlevel.model.spec.name}: {len(samples)} samples")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.tight_layout()
    with replaced_atomically(path) as temporary:
        figure.savefig(temporary, format="png", dpi=110)
    plt.close(figure)
    return path
