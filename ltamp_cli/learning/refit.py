"""Refit a saved GP model directory on its own trials with today's default fit.

A model directory written by ``ltamp train`` (live mode) is a GP fitted on ``DIR/trials.jsonl``
(:mod:`.model_dir`). When the fit changes (e.g. issue #21's lengthscale prior), the model can be
brought up to date without running a trial: :func:`refit_model_dir` reads the trials, fits the GP
exactly as the end of ``ltamp train`` does (:func:`~.active.fit_model` with ``final=True``: a
cold fit with ``gp_restarts`` random restarts, the skill's noise bound, the configured
lengthscale prior; the same random generator as a resumed run at the same budget) and rewrites
the directory, keeping the trainer's metadata (``backend``, ``strategy``, ``training`` …) and
recording the previous hyperparameters under ``refit``. ``ltamp train SKILL --out DIR --refit``
is the command-line form.

A skill that declares an outcome (issue #21) is refitted on its trials *and* their relabelled
points, exactly as training built them (:func:`~.active.learner_from_records`): the outcome
spec is code, so it comes from the skill as its backend declares it (``spec``, which must
match the saved one), never from the directory. ``training.hindsight`` in ``model.json``
says which relabelling the model was trained with (``null``: none; absent, in models saved
before it existed: the default relabelling if the trials carry outcomes, none otherwise); a
model trained with one cannot be refitted without its backend's spec.
"""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.errors import InputError, location_in
from ltamp_cli.learning.active import (
    GP_STRATEGIES,
    LearningConfig,
    fit_model,
    learner_from_records,
    training_metadata,
)
from ltamp_cli.learning.defaults import DEFAULT_STRATEGY
from ltamp_cli.learning.gp import DEFAULT_PRIOR
from ltamp_cli.learning.model_dir import (
    METADATA_FILE,
    LoadedModel,
    checked_spec,
    load_metadata,
    load_model,
    save_model,
    spec_to_json,
)
from ltamp_cli.trials.record import TrialDataset, is_success, without_duplicates

#: Keys :func:`~.model_dir.save_model` writes itself: never copied from the old metadata.
_WRITTEN_BY_SAVE = frozenset({
    "format", "version", "ltamp_version", "saved_at", "kind", "skill", "input_order",
    "normalization", "kernel", "hyperparameters", "n_train", "weights_sha256", "constant",
    "estimator", "data_candidates",
})


def _shape(skill: object) -> object:
    """The parameters and bounds of a saved skill (what must match the backend's)."""
    if not isinstance(skill, dict):
        return None
    return [(part, skill.get(part, {}).get(key)) for part in ("context", "control")
            for key in ("names", "lows", "highs")]


def refit_model_dir(
    directory: str | Path,
    lengthscale_prior_sd: float | None = DEFAULT_PRIOR.log_sd,
    skill: str | None = None,
    spec: SkillSpec | None = None,
) -> LoadedModel:
    """Refit the GP of model ``directory`` on its ``trials.jsonl`` and save it in place.

    ``lengthscale_prior_sd``: log-sd of the lengthscale prior (``None``: maximum marginal
    likelihood, the fit before issue #21). ``skill``, if given, must be the model's skill.
    ``spec``: the skill as its backend declares it (module doc; its outcome, if any, is
    used); ``None``: the saved spec, which has no outcome.
    Strategy, kernel, mean mode and seed come from ``model.json``; every trial in the file
    counts (``training.n_trials`` is updated). Returns the refitted model and its metadata.
    Raises ``InputError`` for a directory that is not a GP model with its trials.
    """
    directory = Path(directory)
    # model.json only, not the old weights: a refit killed between replacing weights.npz and
    # model.json leaves weights its metadata does not match, and the refit that resumes it
    # needs nothing of them (the trials file and the metadata are the whole input).
    metadata = load_metadata(directory)
    where = location_in(directory / METADATA_FILE)
    try:
        saved = checked_spec(metadata.get("skill"))
    except ValueError as error:
        raise InputError(f"incomplete or invalid model directory ({error})", where) from None
    if spec is not None and _shape(spec_to_json(spec)) != _shape(metadata["skill"]):
        raise InputError(f"the backend's skill {spec.name!r} has other parameters or bounds "
                         "than the saved model's: refit with the backend it was trained on",
                         where)
    spec = saved if spec is None else spec
    if metadata.get("kind") != "gp":
        raise InputError(f"only GP models can be refitted, this one is {metadata.get('kind')!r}",
                         where)
    if skill is not None and skill != spec.name:
        raise InputError(f"the model in {directory} is of skill {spec.name!r}, not {skill!r}")
    training = metadata.get("training") if isinstance(metadata.get("training"), dict) else {}
    trials_file = str(training.get("trials_file", "trials.jsonl"))
    path = directory / trials_file
    if Path(trials_file).name != trials_file or not path.is_file():
        raise InputError(f"no trials file {trials_file!r} beside the model: only a model "
                         "trained in live mode (its trials in the directory) can be refitted",
                         where)
    records, _repeats = without_duplicates(TrialDataset(path).read())
    strangers = [r for r in records if r.skill != spec.name]
    if strangers or not records:
        raise InputError(f"{path} must hold trials of skill {spec.name!r} only, and at least one")
    strategy = str(metadata.get("strategy", DEFAULT_STRATEGY))
    hyper = metadata.get("hyperparameters") or {}
    # Models saved before `training.hindsight` existed: relabelled iff their trials carry
    # outcomes (the default since outcomes exist); the shipped push's trials predate them.
    hindsight = training.get("hindsight",
                             {} if any(r.outcome is not None for r in records) else None)
    try:
        if hindsight is not None and not isinstance(hindsight, dict):
            raise ValueError(f"training.hindsight must be an object or null, not "
                             f"{hindsight!r:.40}")
        relabelling = {} if hindsight is None else {
            key: hindsight[name] for key, name in (
                ("hindsight_goals", "goals"), ("hindsight_cap", "cap"),
                ("hindsight_acquisition", "acquisition"),
                ("outcome_own_goal_weight", "own_goal_weight"),
                ("hindsight_theta_data", "theta_data")) if name in hindsight}
        config = LearningConfig(
            strategy=strategy if strategy in GP_STRATEGIES else "gp",
            kernel=str(metadata.get("kernel", "matern52")),
            budget=len(records),
            init=max(1, int(training.get("init", 1))),
            seed=int(training.get("seed", 0)),
            mean=str(hyper.get("mean_mode", "constant")),
            lengthscale_prior_sd=lengthscale_prior_sd,
            hindsight=hindsight is not None,
            **relabelling,
        )
    except (TypeError, ValueError) as error:
        raise InputError(f"model.json: {error}", where) from None
    if isinstance(training.get("hindsight"), dict) and spec.outcome is None:
        raise InputError(f"the model was trained on outcomes of skill {spec.name!r}: refitting "
                         "it needs the skill's outcome from its backend", where)
    # The generator a resumed `ltamp train` at the same budget uses for its final fit, and
    # the same training data (trials + relabelled points) as training built.
    rng = np.random.default_rng([config.seed, len(records)])
    learner = learner_from_records(spec, config, records, rng)
    x, y = learner.training_set()
    model = fit_model(spec, config, x, y, final=True, rng=rng, n_trials=len(records))
    kept = {k: v for k, v in metadata.items() if k not in _WRITTEN_BY_SAVE}
    kept["training"] = {**training, **training_metadata(spec, config),
                        "n_trials": len(records),
                        "n_valid": sum(bool(r.valid) for r in records),
                        "n_success": sum(is_success(r) for r in records)}
    kept["refit"] = {
        "at": datetime.now(UTC).isoformat(timespec="seconds"),
        "lengthscale_prior_sd": lengthscale_prior_sd,
        "previous_hyperparameters": hyper,
        "previous_saved_at": metadata.get("saved_at"),
    }
    save_model(model, directory, **kept)
    return load_model(directory)
