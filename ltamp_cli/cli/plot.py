"""``ltamp plot ...``: pictures of trained models (PNG)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ltamp_cli.errors import InputError


def register(app: typer.Typer) -> None:
    plot_app = typer.Typer(help="Draw pictures of trained models (PNG).", no_args_is_help=True)
    plot_app.command(name="level-set")(level_set_command)
    app.add_typer(plot_app, name="plot")


def parse_dims(text: str, names: tuple[str, ...]) -> tuple[int, int]:
    """``"i,j"`` (indices or control names) -> two different control indices."""
    parts = [part.strip() for part in text.split(",")]
    if len(parts) != 2:
        raise InputError(f"--dims: expected two controls as i,j, got {text!r}")
    dims: list[int] = []
    for part in parts:
        if part in names:
            dims.append(names.index(part))
            continue
        try:
            index = int(part)
        except ValueError:
            raise InputError(f"--dims: {part!r} is neither a control index nor one of "
                             f"{', '.join(names)}") from None
        if not 0 <= index < len(names):
            raise InputError(f"--dims: index {index} out of range [0, {len(names) - 1}] "
                             f"({', '.join(names)})")
        dims.append(index)
    if dims[0] == dims[1]:
        raise InputError(f"--dims: the two controls must differ, got {text!r}")
    return dims[0], dims[1]


def level_set_command(
    model_dir: Annotated[Path, typer.Argument(help="Directory written by `ltamp train`.")],
    out: Annotated[Path, typer.Option("--out", help="PNG file to write.")],
    context: Annotated[
        list[str] | None, typer.Option("--context", help="Context value as name=value (repeat).")
    ] = None,
    dims: Annotated[
        str, typer.Option("--dims", help="Two controls to draw: indices or names, as i,j.")
    ] = "0,1",
    samples: Annotated[
        int, typer.Option("--samples", help="Adaptive samples to draw on top (0: none).")
    ] = 20,
    lam: Annotated[
        float, typer.Option("--lambda", help="Relaxed β: Φ⁻¹(λ Φ(μ/σ at θ*)), λ ∈ [0.95, 0.999].")
    ] = 0.95,
    beta: Annotated[
        float | None, typer.Option("--beta", help="Use this μ/σ threshold instead.")
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of every random choice.")] = 0,
) -> None:
    """Draw MODEL_DIR's predicted level set over two controls, with its training trials.

    Controls not drawn are held at the most confident control θ* of the context.
    """
    import numpy as np
    import torch

    from ltamp_cli.cli.options import check_confidence_options
    from ltamp_cli.cli.sample import parse_context
    from ltamp_cli.learning.model import LevelSetModel
    from ltamp_cli.learning.model_dir import load_model
    from ltamp_cli.sampling.factory import make_sampler
    from ltamp_cli.sampling.level_set_plot import plot_level_set
    from ltamp_cli.sampling.superlevel import build_superlevel_set

    torch.set_num_threads(1)
    if out.suffix.lower() != ".png":
        raise InputError(f"--out: expected a .png file name, got {str(out)!r}")
    if samples < 0:
        raise InputError(f"--samples: expected a number >= 0, got {samples}")
    check_confidence_options(lam, beta)
    model = load_model(model_dir).model
    if not isinstance(model, LevelSetModel):
        raise InputError(f"{model_dir}: level-set plots need a GP model, this one is "
                         f"{model.kind!r}")
    spec = model.spec
    if spec.control.dim < 2:
        raise InputError(f"--dims: {spec.name!r} has {spec.control.dim} control; the level-set "
                         "plot needs 2 (use `ltamp sample --plot` for 1)")
    chosen = parse_dims(dims, spec.control.names)
    values = np.array(parse_context(list(context or []), spec.context.names), dtype=float)
    outside = [f"{name}={v:g} not in [{lo:g}, {hi:g}]" for name, v, lo, hi
               in zip(spec.context.names, values, spec.context.lows, spec.context.highs,
                      strict=True) if not lo <= v <= hi]
    if outside:
        raise InputError(f"--context: outside the trained range: {'; '.join(outside)}")

    superlevel = build_superlevel_set(model, values, np.random.default_rng(seed), beta=beta,
                                      lam=lam)
    drawn = np.empty((0, spec.control.dim))
    if samples:
        sampler = make_sampler("adaptive", model, values, np.random.default_rng(seed + 1),
                               beta=superlevel.beta, lam=lam)
        drawn = np.array([c for _, c in zip(range(samples), sampler, strict=False)]
                         ).reshape(-1, spec.control.dim)
    _, train_controls = model.from_unit(model.gp.x_np)
    success = model.gp.y_np > 0.0
    plot_level_set(superlevel, chosen, out, training_controls=train_controls,
                   training_success=success, samples=drawn)
    typer.echo(f"{out}: {spec.name} level set over {spec.control.names[chosen[0]]}, "
               f"{spec.control.names[chosen[1]]} (β = {superlevel.beta:.3f}, "
               f"{len(train_controls)} trials, {len(drawn)} samples)")
