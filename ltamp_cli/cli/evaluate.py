"""``ltamp evaluate``: F1 on held-out trials and success rate of the most confident control."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ltamp_cli.cli.conventions import progress_enabled
from ltamp_cli.errors import InputError

if TYPE_CHECKING:
    from ltamp_cli.backends.protocol import SkillBackend, TrialResult
    from ltamp_cli.learning.model import SkillModel


def register(app: typer.Typer) -> None:
    app.command(name="evaluate")(evaluate_command)


def evaluate_command(
    model_dir: Annotated[Path, typer.Argument(help="Directory written by `ltamp train`.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    data: Annotated[
        Path | None, typer.Option("--data", help="Held-out trials (JSONL) for F1.")
    ] = None,
    trials: Annotated[
        int, typer.Option("--trials", help="Contexts whose θ* is scored (success rate).")
    ] = 50,
    n_test: Annotated[
        int, typer.Option("--n-test", help="Synthetic backends: held-out points for F1.")
    ] = 2000,
    seed: Annotated[int, typer.Option("--seed", help="Seed for contexts and candidates.")] = 0,
) -> None:
    """Report F1 (positive ⇔ predicted score > 0) and the success rate of θ*.

    On the synthetic backend both use the true score function; on a physical backend F1 needs
    --data and the success rate runs one live trial of θ* per sampled context.
    """
    from ltamp_cli.backends import load_tagged_backend
    from ltamp_cli.cli.conventions import emit
    from ltamp_cli.cli.train import heldout_from_records, read_records
    from ltamp_cli.learning.metrics import SkillEvaluator, wilson_interval
    from ltamp_cli.learning.model_dir import load_model
    from ltamp_cli.threads import use_one_thread
    from ltamp_cli.trials.physics import TrialKind

    use_one_thread()
    if trials < 0 or n_test < 1:
        raise InputError(f"--trials must be >= 0 and --n-test >= 1, got {trials} and {n_test}")
    loaded = load_model(model_dir)
    model, metadata = loaded.model, loaded.metadata
    skill = model.spec.name
    backend_name = str(metadata.get("backend", "synthetic"))
    physics = load_tagged_backend(backend_name)
    try:
        if skill not in physics.skills():
            raise InputError(f"backend {backend_name!r} has no skill {skill!r}")
        # F1 against labels of another backend, robot setup or physics says nothing about
        # the model: the held-out trials must be the kind the live trials run now.
        heldout_kind = TrialKind.of_backend(physics, skill)
        report: dict[str, object] = {
            "model": str(model_dir),
            "kind": model.kind,
            "skill": skill,
            "backend": backend_name,
        }
        if hasattr(physics, "true_score"):
            evaluator = SkillEvaluator.synthetic(
                physics, skill, n_test, max(trials, 0), seed + 12345
            )
            if data is not None:
                evaluator.heldout = heldout_from_records(
                    read_records(data, "--data", heldout_kind, skill), model.spec)
            result = evaluator.evaluate(model, int(metadata.get("training", {}).get("n_trials", 0)))
            report.update(
                f1=result.f1,
                success_rate=result.success_rate,
                n_contexts=trials,
                n_test=len(evaluator.heldout.scores) if evaluator.heldout else 0,
            )
            if result.success_rate is not None and trials > 0:
                report["success_rate_wilson95"] = list(
                    wilson_interval(round(result.success_rate * trials), trials))
        else:
            f1 = None
            if data is not None:
                heldout = heldout_from_records(
                    read_records(data, "--data", heldout_kind, skill), model.spec)
                f1 = heldout.f1(model)
                report["n_test"] = len(heldout.scores)
            report["f1"] = f1
            star, baseline, contexts = _live_outcomes(physics, skill, model, trials, seed)
            report["success_rate"] = sum(star) / trials if trials else None
            report["random_success_rate"] = sum(baseline) / trials if trials else None
            if trials:
                # Rates of a few contexts are claims only with their uncertainty.
                report["success_rate_wilson95"] = list(wilson_interval(sum(star), trials))
                report["random_success_rate_wilson95"] = list(
                    wilson_interval(sum(baseline), trials))
            report["n_contexts"] = trials
            # Per context, in draw order (the same contexts for every model at one --seed):
            # for paired comparisons of two models (e.g. a refit against the shipped one).
            report["successes"] = star
            report["random_successes"] = baseline
            report["contexts"] = contexts
    finally:
        physics.close()
    emit(report, as_json)


def _live_success_rates(
    physics: SkillBackend, skill: str, model: SkillModel, trials: int, seed: int
) -> tuple[float | None, float | None]:
    """Success rates of θ* and of a uniformly random valid control, each run once in the
    same ``trials`` contexts drawn from the backend's context distribution (seeded)."""
    if trials == 0:
        return None, None
    star, baseline, _contexts = _live_outcomes(physics, skill, model, trials, seed)
    return sum(star) / trials, sum(baseline) / trials


def _live_outcomes(
    physics: SkillBackend, skill: str, model: SkillModel, trials: int, seed: int
) -> tuple[list[int], list[int], list[list[float]]]:
    """Per context (``trials`` of them, drawn from the backend's context distribution with
    ``seed``): 1 if θ* succeeded, and 1 if a uniformly random valid control did (each run once,
    same trial seed), else 0; and the contexts ``(trials, dα)`` in physical units. Contexts
    depend on ``seed`` only (θ*'s search draws a fixed number of candidates), so two models
    evaluated at one seed are paired per context."""
    if trials == 0:
        return [], [], []
    import numpy as np  # lazy, like every command's heavy imports: keeps `ltamp --help` fast
    from tqdm import tqdm

    from ltamp_cli.backends.protocol import drawn_context

    rng = np.random.default_rng(seed)
    baseline_rng = np.random.default_rng([seed, 1])
    space = physics.skills()[skill].control
    successes: list[int] = []
    baseline: list[int] = []
    contexts: list[list[float]] = []
    problems: list[str] = []  # reasons of the trials that raised
    for index in tqdm(
        range(trials),
        disable=not progress_enabled(),
        file=sys.stderr,
        desc=f"θ* trials {skill}",
        unit="trial",
    ):
        context = drawn_context(physics, skill, rng)
        contexts.append([round(float(v), 6) for v in np.ravel(context)])
        control, _ = model.most_confident_control(
            context, rng, lambda c, u: physics.is_valid(skill, c, u)
        )
        result = _trial(physics, skill, context, control, seed * 100_003 + index, problems)
        successes.append(int(result.valid and result.score > 0))
        # The baseline: the first valid control of a uniform batch (invalid if none is).
        candidates = space.sample_uniform(baseline_rng, 1000)
        valid = np.flatnonzero(physics.is_valid(skill, context, candidates))
        if len(valid):
            random_result = _trial(physics, skill, context, candidates[valid[0]],
                                   seed * 100_003 + index, problems)
            baseline.append(int(random_result.valid and random_result.score > 0))
        else:
            baseline.append(0)
    if problems:
        typer.echo(f"ltamp: warning: {len(problems)} trial(s) raised (counted as failures), "
                   f"first: {problems[0]}", err=True)
    return successes, baseline, contexts


def _trial(physics: SkillBackend, skill: str, context: Any, control: Any, seed: int,
           problems: list[str]) -> TrialResult:
    """One live trial, as ``collect`` and ``train`` run it (:func:`run_trial_safely`): a
    plugin's ``run_trial`` that raises, returns no ``TrialResult``, a string or NaN score, or
    an invalid "success" is an invalid trial (a failure here), not a traceback; the reasons
    of trials that raised are appended to ``problems``."""
    from ltamp_cli.backends.sanity import run_trial_safely

    result, crashed = run_trial_safely(physics, skill, context, control, seed)
    if crashed:
        problems.append(str(result.info.get("reason", "")))
    return result
