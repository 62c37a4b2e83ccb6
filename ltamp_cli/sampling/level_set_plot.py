"""Picture of a model's predicted super-level set on a 2-D slice of its controls.

For one context, ``μ/σ`` is drawn as a colour map over two chosen control dimensions
``(i, j)`` with the set ``Â_α`` outlined at level ``β``; every other control is held at its
value in ``θ*`` (the most confident control), so the slice passes through the set's most
confident point. Training trials are projected onto the two dimensions (they come from all
contexts, so they only show where the model has data) and samples are drawn as dots.
Written as PNG with the Agg backend.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ltamp_cli.atomic_file import replaced_atomically
from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.sampling.superlevel import SuperLevelSet

GRID = 160
DPI = 110
FIGSIZE_IN = (6.4, 4.8)


def slice_grid(superlevel: SuperLevelSet, dims: tuple[int, int], size: int = GRID
               ) -> np.ndarray:
    """Normalised controls ``(size², dθ)``: a grid over ``dims``, others at ``θ*``."""
    if superlevel.theta_star is None:
        raise ValueError("the super-level set has no θ*: build it with build_superlevel_set")
    axis = np.linspace(-1.0, 1.0, size)
    first, second = np.meshgrid(axis, axis)
    u = np.repeat(superlevel.theta_star[None, :], size * size, axis=0)
    u[:, dims[0]] = first.reshape(-1)
    u[:, dims[1]] = second.reshape(-1)
    return u


def default_title(superlevel: SuperLevelSet, dims: tuple[int, int],
                  spec: SkillSpec | None = None) -> str:
    """What the picture shows: the skill, its context with units (from ``spec``, default
    the model's), β, and where the other controls are held (lines of ~70 characters)."""
    import textwrap

    spec = spec or superlevel.model.spec
    context = ", ".join(
        f"{name} = {value:.3g}" + (f" {spec.context.unit(k)}" if spec.context.unit(k) else "")
        for k, (name, value) in enumerate(zip(spec.context.names,
                                               np.ravel(superlevel.context), strict=True)))
    star = (superlevel.to_physical(superlevel.theta_star[None, :])[0]
            if superlevel.theta_star is not None else None)
    held = [f"{spec.control.names[k]} = {star[k]:.3g}"
            + (f" {spec.control.unit(k)}" if spec.control.unit(k) else "")
            for k in range(superlevel.dim) if k not in dims and star is not None]
    lines = [f"{spec.name}: predicted level set Â (β = {superlevel.beta:.2f})",
             *textwrap.wrap(f"context: {context}" if context else "no context", 70)]
    if held:
        lines += textwrap.wrap(f"held at θ*: {', '.join(held)}", 70)
    return "\n".join(lines)


def plot_level_set(
    superlevel: SuperLevelSet,
    dims: tuple[int, int],
    path: str | Path,
    training_controls: np.ndarray | None = None,
    training_success: np.ndarray | None = None,
    samples: np.ndarray | None = None,
    title: str = "",
    spec: SkillSpec | None = None,
) -> Path:
    """Draw ``Â_α`` over control dims ``dims`` and write a PNG to ``path``.

    ``training_controls (n, dθ)`` and ``samples (k, dθ)`` are physical controls;
    ``training_success (n,)`` is bool (score > 0). Axis labels and the default title take
    names and units from ``spec`` (default: the model's). Returns ``path``.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    i, j = dims
    if i == j or not (0 <= i < superlevel.dim and 0 <= j < superlevel.dim):
        raise ValueError(f"dims must be two different controls in [0, {superlevel.dim}), "
                         f"got {dims}")
    u = slice_grid(superlevel, dims)
    ratio = superlevel.ratio(u).reshape(GRID, GRID)
    physical = superlevel.to_physical(u)
    xs = physical[:, i].reshape(GRID, GRID)
    ys = physical[:, j].reshape(GRID, GRID)

    figure, axes = plt.subplots(figsize=FIGSIZE_IN)
    limit = float(np.nanpercentile(np.abs(ratio), 99)) or 1.0
    mesh = axes.pcolormesh(xs, ys, ratio, cmap="RdBu", vmin=-limit, vmax=limit, shading="auto")
    figure.colorbar(mesh, ax=axes, label="μ/σ")
    if ratio.min() < superlevel.beta < ratio.max():
        axes.contour(xs, ys, ratio, levels=[superlevel.beta], colors="black", linewidths=2)
    if training_controls is not None and len(training_controls):
        controls = np.asarray(training_controls, dtype=float).reshape(-1, superlevel.dim)
        success = (np.ones(len(controls), dtype=bool) if training_success is None
                   else np.asarray(training_success, dtype=bool).reshape(-1))
        axes.scatter(controls[success, i], controls[success, j], s=18, marker="o",
                     color="limegreen", edgecolors="black", linewidths=0.5,
                     label="trials (all contexts): success", zorder=3)
        axes.scatter(controls[~success, i], controls[~success, j], s=18, marker="x",
                     color="crimson", label="trials (all contexts): failure", zorder=3)
    if samples is not None and len(samples):
        points = np.asarray(samples, dtype=float).reshape(-1, superlevel.dim)
        axes.scatter(points[:, i], points[:, j], s=14, color="gold", edgecolors="black",
                     linewidths=0.5, label="samples", zorder=4)
    axes.set_xlim(float(xs.min()), float(xs.max()))
    axes.set_ylim(float(ys.min()), float(ys.max()))
    control = (spec or superlevel.model.spec).control
    axes.set_xlabel(control.label(i))
    axes.set_ylabel(control.label(j))
    if axes.get_legend_handles_labels()[0]:
        axes.legend(loc="best", fontsize=8)
    axes.set_title(title or default_title(superlevel, dims, spec), fontsize=9)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.tight_layout()
    with replaced_atomically(path) as temporary:
        figure.savefig(temporary, format="png", dpi=DPI)
    plt.close(figure)
    return path
