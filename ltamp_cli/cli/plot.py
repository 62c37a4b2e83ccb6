"""``ltamp plot ...``: pictures of trained models (PNG)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from ltamp_cli.cli.conventions import emit, progress_enabled
from ltamp_cli.cli.paths import writable_output_file
from ltamp_cli.errors import InputError
from ltamp_cli.seeds import usable_seed

if TYPE_CHECKING:
    from ltamp_cli.backends.protocol import SkillSpec


def register(app: typer.Typer) -> None:
    plot_app = typer.Typer(help="Draw pictures of trained models (PNG).", no_args_is_help=True)
    plot_app.command(name="level-set")(level_set_command)
    plot_app.command(name="curves")(curves_command)
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
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
) -> None:
    """Draw MODEL_DIR's predicted level set over two controls, with its training trials.

    Controls not drawn are held at the most confident control θ* of the context.
    """
    import numpy as np

    from ltamp_cli.cli.options import check_confidence_options
    from ltamp_cli.cli.sample import parse_context
    from ltamp_cli.learning.model import LevelSetModel
    from ltamp_cli.learning.model_dir import load_model
    from ltamp_cli.sampling.factory import make_sampler, outside_trained_range
    from ltamp_cli.sampling.level_set_plot import plot_level_set
    from ltamp_cli.sampling.superlevel import build_superlevel_set
    from ltamp_cli.threads import use_one_thread

    use_one_thread()
    if out.suffix.lower() != ".png":
        raise InputError(f"--out: expected a .png file name, got {str(out)!r}")
    writable_output_file(out, "--out")
    if samples < 0:
        raise InputError(f"--samples: expected a number >= 0, got {samples}")
    check_confidence_options(lam, beta)
    loaded = load_model(model_dir)
    model = loaded.model
    if not isinstance(model, LevelSetModel):
        raise InputError(f"{model_dir}: level-set plots need a GP model, this one is "
                         f"{model.kind!r}")
    spec = model.spec
    if spec.control.dim < 2:
        raise InputError(f"--dims: {spec.name!r} has {spec.control.dim} control; the level-set "
                         "plot needs 2 (use `ltamp sample --plot` for 1)")
    chosen = parse_dims(dims, spec.control.names)
    values = np.array(parse_context(list(context or []), spec.context.names), dtype=float)
    outside = outside_trained_range(spec, values)
    if outside:
        raise InputError(f"--context: outside the trained range: {outside}")

    seed = usable_seed(seed)
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
                   training_success=success, samples=drawn,
                   spec=_spec_with_units(spec, loaded.metadata.get("backend")))
    summary = {"out": str(out), "skill": spec.name,
               "dims": [spec.control.names[chosen[0]], spec.control.names[chosen[1]]],
               "beta": float(superlevel.beta), "trials": len(train_controls),
               "samples": len(drawn)}
    emit(summary, as_json, lambda s: [
        f"{out}: {spec.name} level set over {s['dims'][0]}, {s['dims'][1]} "
        f"(β = {s['beta']:.3f}, {s['trials']} trials, {s['samples']} samples)"])


def _spec_with_units(spec: SkillSpec, backend_name: object) -> SkillSpec:
    """``spec``, or the backend's current spec of the same skill (same parameter names)
    when only that one names units (models saved before specs had units)."""
    if spec.context.units or spec.control.units or not isinstance(backend_name, str):
        return spec
    from ltamp_cli.backends import load_tagged_backend

    try:
        backend = load_tagged_backend(backend_name)
    except (InputError, ImportError, RuntimeError):
        return spec  # only labels are at stake: plot without units
    try:
        current = backend.skills().get(spec.name)
    finally:
        backend.close()
    if (current is not None and current.context.names == spec.context.names
            and current.control.names == spec.control.names):
        return current
    return spec


def curves_command(
    out: Annotated[Path, typer.Option("--out", help="PNG file to write (JSON beside it).")],
    runs: Annotated[list[Path] | None, typer.Argument(
        help="Model directories trained with --eval-every/--curve (one line per strategy; "
        "runs of the same strategy are averaged).")] = None,
    strategies: Annotated[str | None, typer.Option(
        "--strategies", help="Instead of RUNS: train these strategies (comma-separated) on "
        "--skill of the synthetic backend and plot them.")] = None,
    skill: Annotated[str, typer.Option("--skill", help="Synthetic skill for --strategies.")
                     ] = "moving2d",
    budget: Annotated[int, typer.Option("--budget", help="Trials per training run.")] = 40,
    init: Annotated[int, typer.Option("--init", help="Random trials before active ones.")] = 10,
    seeds: Annotated[int, typer.Option("--seeds", help="Training runs per strategy.")] = 1,
    eval_every: Annotated[int, typer.Option("--eval-every", help="Evaluate every K trials.")
                          ] = 10,
    kernel: Annotated[str, typer.Option("--kernel", help="rbf, matern52 or mlp.")
                      ] = "matern52",
    seed: Annotated[int, typer.Option("--seed", help="Seed of the first run.")] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
) -> None:
    """F1 and success rate against the number of trials, every strategy on one figure.

    Either from saved models (RUNS) or, with --strategies, by training each strategy on a
    synthetic skill. Writes OUT (PNG) and OUT with a .json suffix (the plotted data).
    """
    from ltamp_cli.learning.curves import rows_from_model_metadata, train_curves, write_curves

    if out.suffix.lower() != ".png":
        raise InputError(f"--out: expected a .png file name, got {str(out)!r}")
    writable_output_file(out, "--out")
    if bool(runs) == (strategies is not None):
        raise InputError("plot curves: give model directories or --strategies, not both "
                         "(and not neither)")
    rows: list[dict] = []
    if runs:
        from ltamp_cli.learning.model_dir import load_model

        skills: set[str] = set()
        for run in runs:
            loaded = load_model(run)
            skills.add(str(loaded.model.spec.name))
            try:
                rows.extend(rows_from_model_metadata(loaded.metadata))
            except ValueError as error:
                raise InputError(f"{run}: {error}") from None
        title = f"{', '.join(sorted(skills))}: {len(runs)} run(s)"
    else:
        from ltamp_cli.backends import load_backend
        from ltamp_cli.learning.active import STRATEGIES
        from ltamp_cli.threads import use_one_thread

        names = [name.strip() for name in (strategies or "").split(",") if name.strip()]
        unknown = [name for name in names if name not in STRATEGIES]
        if not names or unknown:
            raise InputError(f"--strategies: expected names from {', '.join(STRATEGIES)}, "
                             f"got {strategies!r}")
        for option, value, low in (("--budget", budget, 1), ("--seeds", seeds, 1),
                                   ("--eval-every", eval_every, 1), ("--init", init, 1)):
            if value < low:
                raise InputError(f"{option}: expected a number >= {low}, got {value}")
        use_one_thread()
        backend = load_backend("synthetic")
        try:
            if skill not in backend.skills():
                raise InputError(f"--skill: the synthetic backend has no skill {skill!r} "
                                 f"(known: {', '.join(sorted(backend.skills()))})")
            try:
                rows = train_curves(backend, skill, names, budget=budget, seeds=seeds,
                                    eval_every=eval_every, init=init, kernel=kernel,
                                    seed=seed, progress=progress_enabled())
            except ValueError as error:
                raise InputError(str(error)) from None
        finally:
            backend.close()
        title = f"synthetic/{skill}: {seeds} seed(s), {kernel}"
    try:
        png, data = write_curves(rows, out, title=title)
    except ValueError as error:
        raise InputError(f"plot curves: {error}") from None
    learners = sorted({str(row["learner"]) for row in rows})
    emit({"out": str(png), "data": str(data), "learners": learners}, as_json,
         lambda _: [f"{png}: learning curves of {', '.join(learners)} (data: {data})"])
