"""``ltamp train``: learn a skill model from live trials (or a pool of recorded trials)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from ltamp_cli.cli.paths import writable_output_file
from ltamp_cli.errors import InputError
from ltamp_cli.learning.defaults import DEFAULT_STRATEGY
from ltamp_cli.seeds import usable_seed
from ltamp_cli.writer_lock import holds_writer_lock


def register(app: typer.Typer) -> None:
    app.command(name="train")(train_command)


def heldout_from_records(records: list[Any], spec: Any) -> Any:
    """A :class:`~ltamp_cli.learning.metrics.HeldOutSet` from the trial records of skill
    ``spec`` (a :class:`~ltamp_cli.backends.protocol.SkillSpec`), labelled as training labels
    them (an invalid trial is never a success); records of wrong lengths or far outside the
    skill's bounds are refused in one line."""
    from ltamp_cli.learning.metrics import HeldOutSet
    from ltamp_cli.trials.record import check_against_spec, records_to_arrays

    records = [r for r in records if r.skill == spec.name]
    if not records:
        raise InputError(f"the held-out data has no trials of skill {spec.name!r}")
    try:
        check_against_spec(records, spec)
    except ValueError as error:
        raise InputError(f"held-out data: {error}") from None
    contexts, controls, scores, _valid = records_to_arrays(records, spec.invalid_score)
    return HeldOutSet(contexts, controls, scores)


def read_records(path: Path, option: str, kind: Any = None, skill: str | None = None
                 ) -> list[Any]:
    """The trial records of ``path`` (each repeated trial once, with a warning). With
    ``kind`` (a :class:`~ltamp_cli.trials.physics.TrialKind`), every record of ``skill``
    must be of that kind: another backend, robot setup or physics is one ``file:line``
    error naming both values."""
    from ltamp_cli.textfile import not_a_file
    from ltamp_cli.trials.physics import check_trial_kind
    from ltamp_cli.trials.record import TrialDataset, without_duplicates

    if not path.is_file():
        raise InputError(f"{option}: {not_a_file(path)}")
    numbered = list(TrialDataset(path).iter_numbered())
    if kind is not None:
        check_trial_kind(((f"{path}:{line}", r) for line, r in numbered
                          if r.skill == skill), kind,
                         f"{option}: expected as the {kind.backend} backend runs them now",
                         "use trials collected with the same backend, robot and physics, "
                         "or the backend options they were collected with")
    records, repeats = without_duplicates([r for _line, r in numbered])
    if repeats:
        typer.echo(f"ltamp: warning: {option}: {path} repeats {repeats} trial record(s) with the "
                   "same (seed, index); each trial is used once", err=True)
    if not records:
        raise InputError(f"{option}: {path} holds no trial records")
    return records


# One writer per model directory: a concurrent `tell` or `train` would otherwise record its
# trial under the other's model.
@holds_writer_lock("out", is_directory=True)
def train_command(
    skill: Annotated[str, typer.Argument(help="Skill to learn (see `ltamp skills`).")],
    out: Annotated[Path, typer.Option("--out", help="Model directory to write (resumes).")],
    backend: Annotated[
        str, typer.Option("--backend", help="Backend that runs trials.")
    ] = "synthetic",
    strategy: Annotated[
        str, typer.Option("--strategy", help="lse (straddle over control and context), lse2 "
                          "(over the controls of a drawn context), random, gp, nn-c, nn-r, rf-c "
                          "or rf-r.")
    ] = DEFAULT_STRATEGY,
    budget: Annotated[int, typer.Option("--budget", help="Total number of trials.")] = 50,
    init: Annotated[int, typer.Option("--init", help="Random trials before active ones.")] = 10,
    explore_until_success: Annotated[
        bool,
        typer.Option(
            "--explore-until-success/--no-explore-until-success",
            help="Active strategies: keep trials random after --init until one succeeds "
            "(score > 0); without a success the straddle only chases uncertainty.",
        ),
    ] = True,
    hindsight: Annotated[
        bool,
        typer.Option(
            "--hindsight/--no-hindsight",
            help="Skills that declare an outcome (e.g. the 2D push's end position): also "
            "learn from each trial relabelled for other goals (achieved goal + 4 drawn, at "
            "most 300 relabelled points); lse then chooses the trial expected to reach the "
            "most goals no trial has reached (a GP on the outcomes). No effect on other "
            "skills.",
        ),
    ] = True,
    kernel: Annotated[str, typer.Option("--kernel", help="rbf, matern52 or mlp.")] = "matern52",
    seed: Annotated[int, typer.Option("--seed", help="Seed of every random choice.")] = 0,
    data: Annotated[
        Path | None, typer.Option("--data", help="Pool mode: choose trials from this JSONL.")
    ] = None,
    test_data: Annotated[
        Path | None, typer.Option("--test-data", help="Held-out JSONL for F1 on the curve.")
    ] = None,
    eval_every: Annotated[
        int, typer.Option("--eval-every", help="Evaluate every K trials (learning curve).")
    ] = 0,
    curve: Annotated[
        Path | None, typer.Option("--curve", help="Write the learning curve to this PNG.")
    ] = None,
    ask: Annotated[
        bool, typer.Option("--ask", help="Propose the next trial (see `ltamp tell`), not run it.")
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
    wait: Annotated[
        bool, typer.Option("--wait", help="Wait for another writer of --out instead of failing.")
    ] = False,
    robot: Annotated[
        str,
        typer.Option(
            "--robot",
            help="Live trials' robot: 'none' (free-floating tool) or 'panda' (pybullet "
            "pour, scoop, push, stir: the Panda grasps and carries the tool; reach, arm "
            "collisions and slip fail). The model and its trials are tagged pybullet+panda.",
        ),
    ] = "none",
    refit: Annotated[
        bool,
        typer.Option(
            "--refit",
            help="Run no trial: refit OUT's GP on OUT/trials.jsonl with today's default fit "
            "(strategy, kernel and seed from OUT/model.json; --budget etc. are ignored) and "
            "save it in place, keeping the training metadata.",
        ),
    ] = False,
) -> None:
    """Learn SKILL's success constraint and save the model to --out.

    Live mode runs trials on --backend and appends them to OUT/trials.jsonl (a rerun resumes);
    pool mode (--data) picks trials from recorded ones instead; --refit refits an existing
    model directory on its own trials.
    """
    from ltamp_cli.backends import load_backend
    from ltamp_cli.backends.protocol import trial_setup
    from ltamp_cli.cli.collect import check_robot
    from ltamp_cli.cli.conventions import emit, progress_enabled
    from ltamp_cli.learning.active import (
        LearningConfig,
        learn_from_pool,
        learn_online,
        training_metadata,
    )
    from ltamp_cli.learning.confidence import beta_star
    from ltamp_cli.learning.curves import plot_curves
    from ltamp_cli.learning.metrics import SkillEvaluator
    from ltamp_cli.threads import use_one_thread
    from ltamp_cli.trials.physics import TrialKind
    from ltamp_cli.trials.record import TrialDataset, is_success

    use_one_thread()
    if refit:
        if data is not None or ask:
            raise InputError("--refit refits OUT on its own trials: it cannot be used with "
                             "--data or --ask")
        from ltamp_cli.learning.ask_tell import backend_spec
        from ltamp_cli.learning.model_dir import load_metadata
        from ltamp_cli.learning.refit import refit_model_dir

        # The skill's outcome (code) comes from its backend, never from the directory.
        saved = load_metadata(out)
        trained_on, saved_skill = saved.get("backend"), saved.get("skill")
        name = saved_skill.get("name") if isinstance(saved_skill, dict) else None
        declared = (backend_spec(trained_on if isinstance(trained_on, str) else backend, name)
                    if isinstance(name, str) and name == skill else None)
        refitted = refit_model_dir(out, skill=skill, spec=declared)
        emit({"model": str(out), "kind": refitted.model.kind,
              "n_trials": refitted.metadata["training"]["n_trials"],
              "hyperparameters": refitted.metadata["hyperparameters"],
              "previous_hyperparameters": refitted.metadata["refit"]["previous_hyperparameters"]},
             as_json)
        return
    seed = usable_seed(seed)
    try:
        config = LearningConfig(
            strategy=strategy, kernel=kernel, budget=budget, init=init, seed=seed,
            explore_until_success=explore_until_success, hindsight=hindsight,
        )
    except ValueError as error:
        raise InputError(str(error)) from None
    if out.exists() and not out.is_dir():
        raise InputError(f"--out: {out} exists and is not a directory")
    if eval_every < 0:
        raise InputError(f"--eval-every: expected a number >= 0, got {eval_every}")
    if curve is not None:
        writable_output_file(curve, "--curve")
    if curve is not None and eval_every == 0:
        eval_every = max(1, budget // 10)

    check_robot(robot, backend, skill)
    physics = load_backend(backend, **({} if robot == "none" else {"robot": robot}))
    try:
        specs = physics.skills()
        if skill not in specs:
            raise InputError(
                f"backend {backend!r} has no skill {skill!r} (known: {', '.join(sorted(specs))})"
            )
        spec = specs[skill]
        setup = trial_setup(physics, skill)  # the live trials' versioned setup, if any
        if ask:
            if data is not None:
                raise InputError("--ask proposes live trials: it cannot be used with --data")
            from ltamp_cli.learning.ask_tell import ask as ask_next

            emit(ask_next(physics, skill, config, out).to_json(), as_json)
            return
        evaluator = None
        if eval_every > 0:
            if test_data is not None:
                heldout = heldout_from_records(
                    read_records(test_data, "--test-data", TrialKind.of_backend(physics, skill),
                                 skill), spec)
                evaluator = SkillEvaluator(spec, heldout)
            elif hasattr(physics, "true_score"):
                evaluator = SkillEvaluator.synthetic(physics, skill, seed=seed + 12345)
            else:
                raise InputError("--curve/--eval-every on a physical backend needs --test-data")
        progress = progress_enabled()
        if data is not None:
            kind = TrialKind.of_backend(physics, skill)
            pool = read_records(data, "--data", kind, skill)
            try:
                result = learn_from_pool(spec, pool, config, evaluator, eval_every, progress,
                                         kind=kind)
            except ValueError as error:
                raise InputError(f"--data: {error}") from None
            trials_file = str(data.resolve())
        else:
            out.mkdir(parents=True, exist_ok=True)
            dataset = TrialDataset(out / "trials.jsonl")
            try:
                result = learn_online(
                    physics, skill, config, dataset, evaluator, eval_every, progress
                )
            except ValueError as error:
                raise InputError(str(error)) from None
            trials_file = "trials.jsonl"
    finally:
        physics.close()

    curve_rows = [
        {"learner": strategy, "n_trials": p.n_trials, "f1": p.f1, "success_rate": p.success_rate}
        for p in result.curve
    ]
    result.model.save(
        str(out),
        backend=backend if robot == "none" else f"{backend}+{robot}",
        **({"setup": setup} if setup is not None and data is None else {}),
        strategy=strategy,
        training={
            "mode": "pool" if data is not None else "online",
            "n_trials": len(result.records),
            "n_valid": sum(r.valid for r in result.records),
            "n_success": sum(is_success(r) for r in result.records),
            "budget": budget,
            "init": init,
            "seed": seed,
            "trials_file": trials_file,
            **training_metadata(spec, config),
        },
        beta={"lambda": 0.95, "delta": 0.05, "beta_star_50": beta_star(0.05, count=50)},
        curve=curve_rows,
    )
    if curve is not None and curve_rows:
        plot_curves(curve_rows, curve, title=f"{backend}/{skill}: {strategy}")
    summary = {"model": str(out), "kind": result.model.kind, "n_trials": len(result.records)}
    if curve_rows:
        summary.update({k: curve_rows[-1][k] for k in ("f1", "success_rate")})
    emit(summary, as_json)
