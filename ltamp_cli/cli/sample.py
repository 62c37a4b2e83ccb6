"""``ltamp sample``: controls from a trained model's super-level set for one context."""

from __future__ import annotations

import json
import logging
import math
import time
from pathlib import Path
from typing import Annotated

import typer

from ltamp_cli.cli.paths import existing_input_file, writable_output_file
from ltamp_cli.errors import InputError
from ltamp_cli.seeds import usable_seed


def register(app: typer.Typer) -> None:
    app.command(name="sample")(sample_command)


def parse_context(items: list[str], names: tuple[str, ...]) -> list[float]:
    """``["name=value", ...]`` -> values in the order of ``names`` (every name exactly once)."""
    values: dict[str, float] = {}
    for item in items:
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise InputError(f"--context: expected name=value, got {item!r}")
        if name not in names:
            raise InputError(f"--context: unknown context {name!r} (expected "
                             f"{', '.join(names) or 'none: this skill has no context'})")
        if name in values:
            raise InputError(f"--context: {name!r} given twice")
        try:
            value = float(text)
        except ValueError:
            raise InputError(f"--context {name}: expected a number, got {text!r}") from None
        if not math.isfinite(value):
            raise InputError(f"--context {name}: expected a finite number, got {text!r}")
        values[name] = value
    missing = [n for n in names if n not in values]
    if missing:
        raise InputError(f"--context: missing {', '.join(missing)} (give each as name=value)")
    return [values[n] for n in names]


def sample_command(
    model_dir: Annotated[Path, typer.Argument(help="Directory written by `ltamp train`.")],
    context: Annotated[
        list[str] | None, typer.Option("--context", help="Context value as name=value (repeat).")
    ] = None,
    n: Annotated[int, typer.Option("-n", help="Number of samples.")] = 50,
    sampler: Annotated[
        str, typer.Option("--sampler", help="rejection, adaptive, diverse or diverse-lk.")
    ] = "adaptive",
    seed: Annotated[int, typer.Option("--seed", help="Seed of every random choice.")] = 0,
    lam: Annotated[
        float, typer.Option("--lambda", help="Relaxed β: Φ⁻¹(λ Φ(μ/σ at θ*)), λ ∈ [0.95, 0.999].")
    ] = 0.95,
    beta: Annotated[
        float | None, typer.Option("--beta", help="Use this μ/σ threshold instead.")
    ] = None,
    kernel_file: Annotated[
        Path | None,
        typer.Option("--kernel-file", help="diverse-lk: learned kernel to use (JSON)."),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    plot: Annotated[
        Path | None, typer.Option("--plot", help="Draw samples over the level set (PNG).")
    ] = None,
) -> None:
    """Draw N controls with μ/σ > β for one context from MODEL_DIR's GP."""
    import numpy as np

    from ltamp_cli.cli.options import check_confidence_options
    from ltamp_cli.learning.model import LevelSetModel
    from ltamp_cli.learning.model_dir import load_model
    from ltamp_cli.sampling.factory import (
        SAMPLER_NAMES,
        make_sampler,
        outside_trained_range,
    )
    from ltamp_cli.sampling.kernel_learning import load_kernel
    from ltamp_cli.threads import use_one_thread

    use_one_thread()
    if sampler not in SAMPLER_NAMES:
        raise InputError(f"--sampler: unknown sampler {sampler!r} (expected "
                         f"{', '.join(SAMPLER_NAMES)})")
    if n < 1:
        raise InputError(f"-n: expected a number >= 1, got {n}")
    check_confidence_options(lam, beta)
    if plot is not None and plot.suffix.lower() != ".png":
        raise InputError(f"--plot: expected a .png file name, got {str(plot)!r}")
    if plot is not None:
        writable_output_file(plot, "--plot")
    if kernel_file is not None:
        existing_input_file(kernel_file, "--kernel-file")
    model = load_model(model_dir).model
    if not isinstance(model, LevelSetModel):
        raise InputError(f"{model_dir}: sampling needs a GP model, this one is {model.kind!r}")
    spec = model.spec
    if plot is not None and spec.control.dim not in (1, 2):
        raise InputError(f"--plot: only for 1 or 2 controls, {spec.name!r} has "
                         f"{spec.control.dim}")
    values = np.array(parse_context(list(context or []), spec.context.names))
    outside = outside_trained_range(spec, values)
    if outside:
        raise InputError(f"--context: outside the trained range: {outside}")
    kernel = load_kernel(kernel_file, spec) if kernel_file is not None else None

    start = time.perf_counter()
    rng = np.random.default_rng(usable_seed(seed))
    chosen = make_sampler(sampler, model, values, rng, beta=beta,
                          lam=lam, kernel=kernel)
    samples = [control for _, control in zip(range(n), chosen, strict=False)]
    elapsed = time.perf_counter() - start
    result = {
        "model": str(model_dir),
        "skill": spec.name,
        "sampler": sampler,
        "context": dict(zip(spec.context.names, values.tolist(), strict=True)),
        "beta": chosen.beta,
        "phi_star": (chosen.superlevel.phi_star
                     if math.isfinite(chosen.superlevel.phi_star) else None),
        "time_s": round(elapsed, 6),
        "samples": [dict(zip(spec.control.names, map(float, s), strict=True)) for s in samples],
    }
    if plot is not None:
        from ltamp_cli.sampling.plot import plot_samples

        plot_samples(chosen.superlevel, np.array(samples), plot,
                     title=f"{spec.name}: {len(samples)} {sampler} samples")
        result["plot"] = str(plot)
    if not chosen.superlevel.phi_star > 0 and \
            logging.getLogger("ltamp").isEnabledFor(logging.WARNING):
        # μ ≤ 0 even at the most confident control: the relaxed β still makes a set (around
        # θ*), but nothing in it is predicted to succeed
        typer.echo(f"ltamp: warning: the model predicts failure at every control for this "
                   f"context (μ/σ at θ* = {chosen.superlevel.phi_star:.3g} <= 0): the samples "
                   "are its least bad guesses, not a learned set", err=True)
    if as_json:
        typer.echo(json.dumps(result))
    else:
        typer.echo(f"{spec.name}: {len(samples)} {sampler} samples, β = {chosen.beta:.3f}, "
                   f"{elapsed:.3f} s")
        typer.echo("  ".join(f"{name:>10}" for name in spec.control.names))
        for s in samples:
            typer.echo("  ".join(f"{v:>10.6g}" for v in s))
    if len(samples) < n:
        typer.echo(f"ltamp: only {len(samples)} of {n} samples: the set looks (almost) empty",
                   err=True)
        raise typer.Exit(1)
