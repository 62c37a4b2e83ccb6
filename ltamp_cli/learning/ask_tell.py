"""Ask/tell active learning for trials run outside ltamp (e.g. on a real robot).

:func:`ask` proposes the next trial without running it and writes ``DIR/pending.json``;
:func:`tell` records its outcome in ``DIR/trials.jsonl``, refits the model, saves it to ``DIR``
and only then removes ``pending.json``. Every step leaves a consistent directory on disk, and a
``tell`` repeated after a crash never records the same trial twice (the pending trial's
``index`` is checked against the file).

A skill that declares an outcome (issue #21) is learned as in ``ltamp train``: the trials
and their relabelled points (:func:`~.active.learner_from_records`), the outcome acquisition
if configured. :func:`tell` then takes the trial's outcome beside its score; the outcome spec
(code) comes from the skill as its backend declares it, which :func:`tell` loads by the
pending trial's backend name — never from ``pending.json``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.protocol import SkillBackend, SkillSpec, trial_setup
from ltamp_cli.backends.sanity import checked_outcome
from ltamp_cli.errors import InputError, location_in
from ltamp_cli.jsondata import read_json_data
from ltamp_cli.learning.active import (
    LearningConfig,
    _propose,
    _trial_seed,
    check_same_trials,
    fit_model,
    goes_active,
    learner_from_records,
    training_metadata,
)
from ltamp_cli.learning.model import SkillModel
from ltamp_cli.learning.model_dir import (
    METADATA_FILE,
    checked_spec,
    load_model,
    spec_to_json,
)
from ltamp_cli.trials.physics import backend_physics
from ltamp_cli.trials.record import (
    MAX_SCORE_MAGNITUDE,
    TrialDataset,
    TrialRecord,
    check_against_spec,
    is_success,
)
from ltamp_cli.writer_lock import exclusive_writer

PENDING_FILE = "pending.json"
TRIALS_FILE = "trials.jsonl"


@dataclass(frozen=True)
class Proposal:
    """The trial to run next; ``context``/``control`` in physical units, by parameter name.
    ``setup``: the versioned trial setup it was proposed for (``"panda-r3"``,
    :func:`~ltamp_cli.backends.protocol.trial_setup`), which the told record carries; in the
    JSON only when there is one. ``physics``: likewise the backend's physics tag
    (:func:`~ltamp_cli.trials.physics.backend_physics`): the told trial is labelled for that
    backend's skill, so it resumes with live trials of it and never with another physics'."""

    skill: str
    backend: str
    index: int
    seed: int
    context: dict[str, float]
    control: dict[str, float]
    setup: str | None = None
    physics: str | None = None

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        for optional in ("setup", "physics"):
            if data[optional] is None:
                del data[optional]
        return data


def _write_json(path: Path, data: dict[str, Any]) -> None:
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text(json.dumps(data, indent=2, sort_keys=True, allow_nan=False) + "\n")
    with temporary.open("rb") as handle:
        os.fsync(handle.fileno())
    temporary.replace(path)


def _previous_model(directory: Path) -> SkillModel | None:
    if not (directory / METADATA_FILE).is_file():
        return None
    return load_model(directory).model


def backend_spec(backend_name: str, skill: str) -> SkillSpec | None:
    """The skill as backend ``backend_name`` declares it (``"pybullet+panda"``: with that
    robot), or ``None`` when the backend cannot be loaded here or lacks the skill."""
    from ltamp_cli.backends import load_tagged_backend

    try:
        backend = load_tagged_backend(backend_name)
    except Exception:  # an unknown plugin, a missing optional dependency: no outcome
        return None
    try:
        return backend.skills().get(skill)
    except Exception:
        return None
    finally:
        backend.close()


def ask(
    backend: SkillBackend, skill: str, config: LearningConfig, directory: str | Path
) -> Proposal:
    """Propose the next trial of ``skill`` and save it as ``DIR/pending.json``.

    Asking again before telling returns the same pending proposal. The first ``config.init``
    proposals are random; later ones maximise the straddle of the model fitted on
    ``DIR/trials.jsonl`` (for ``lse``/``lse2``).
    """
    directory = Path(directory)
    pending_path = directory / PENDING_FILE
    if pending_path.is_file():
        pending = _read_pending(directory)
        if pending["proposal"]["skill"] != skill:
            raise InputError(
                f"a trial of skill {pending['proposal']['skill']!r} is pending here; "
                "tell its outcome first",
                location_in(pending_path),
            )
        return Proposal(**pending["proposal"])
    spec = backend.skills()[skill]
    dataset = TrialDataset(directory / TRIALS_FILE)
    records = dataset.read()
    # The trials a proposal is fitted on are the ones `ltamp train` would resume with.
    try:
        check_same_trials(records, backend, skill, str(dataset.path))
    except ValueError as error:
        raise InputError(str(error)) from None
    rng = np.random.default_rng([config.seed, len(records), 7])
    model: SkillModel | None = None
    learner = learner_from_records(spec, config, records, rng)
    outcome_model = None
    if goes_active(config, learner.scores(), len(records)):
        x, y = learner.training_set()
        model = fit_model(spec, config, x, y, _previous_model(directory), rng=rng,
                          n_trials=len(records))
        outcome_model = learner.outcome_model()

    def is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return backend.is_valid(skill, context, controls)

    context, control = _propose(backend, skill, spec, config, rng, model, is_valid,
                                outcome_model)
    index = len(records)
    proposal = Proposal(
        skill=skill,
        backend=backend.name,
        index=index,
        seed=_trial_seed(config.seed, index),
        context={n: float(v) for n, v in zip(spec.context.names, context, strict=True)},
        control={n: float(v) for n, v in zip(spec.control.names, control, strict=True)},
        setup=trial_setup(backend, skill),
        physics=backend_physics(backend, skill),
    )
    directory.mkdir(parents=True, exist_ok=True)
    _write_json(
        pending_path,
        {"proposal": proposal.to_json(), "spec": spec_to_json(spec), "config": asdict(config),
         # data, not code: tell loads the outcome spec from the backend when this is true
         "has_outcome": spec.outcome is not None},
    )
    return proposal


def _read_pending(directory: Path) -> dict[str, Any]:
    path = directory / PENDING_FILE
    if not path.is_file():
        raise InputError(
            "no pending trial: run `ltamp train SKILL --ask --out DIR` first",
            location_in(directory),
        )
    try:
        data = read_json_data(path)
        spec = checked_spec(data["spec"])
        LearningConfig(**data["config"])
        proposal = Proposal(**data["proposal"])
        _pending_record(spec, proposal)
    except (ValueError, KeyError, TypeError, AttributeError) as error:
        raise InputError(
            f"corrupt pending trial ({type(error).__name__}: {error})", location_in(path)
        ) from None
    return data


def _pending_record(spec: SkillSpec, proposal: Proposal) -> TrialRecord:
    """The trial record of ``proposal`` (score 0 until told), checked like a line of a
    trial file: the spec's names exactly, finite numbers near the skill's box, integer
    seed and index >= 0, the spec's skill (``ValueError``/``TypeError``/``KeyError``)."""
    for part, values, space in (("context", proposal.context, spec.context),
                                ("control", proposal.control, spec.control)):
        if not isinstance(values, dict) or sorted(values) != sorted(space.names):
            raise ValueError(f"proposal {part} must name {', '.join(space.names)}, got "
                             f"{values!r:.60}")
    if proposal.skill != spec.name:
        raise ValueError(f"proposal of skill {proposal.skill!r:.40}, spec of {spec.name!r}")
    record = TrialRecord.from_dict({
        "skill": proposal.skill, "backend": proposal.backend, "seed": proposal.seed,
        "index": proposal.index, "score": 0.0, "valid": True,
        "context": [proposal.context[n] for n in spec.context.names],
        "control": [proposal.control[n] for n in spec.control.names],
        "setup": proposal.setup, "physics": proposal.physics})
    if record.index < 0:
        raise ValueError(f"proposal index must be >= 0, got {record.index}")
    check_against_spec([record], spec)
    return record


def tell(directory: str | Path, score: float, valid: bool = True, *,
         wait: bool = False, outcome: Sequence[float] | None = None,
         spec: SkillSpec | None = None) -> TrialRecord:
    """Record the result of the pending trial, refit and save the model, clear the pending.

    ``outcome``: what the trial observed, for a skill that declares an outcome (physical
    units, ``(d_outcome,)``); it must fit the declared outcome and reproduce ``score``.
    ``spec``: the skill as its backend declares it (default: loaded from the pending trial's
    backend, module doc). Raises :class:`InputError` when nothing is pending, ``score`` is not
    finite or ``outcome`` does not fit.
    """
    directory = Path(directory)
    if not np.isfinite(score):
        raise InputError(f"--score: expected a finite number, got {score}")
    if abs(score) > MAX_SCORE_MAGNITUDE:  # the refit would overflow (and training refuses it)
        raise InputError(f"--score: {score:g} is beyond ±{MAX_SCORE_MAGNITUDE:g}")
    if not valid and score > 0:  # learned as is, a trial that could not run would "succeed"
        raise InputError(f"--score {score:g} is a success, but --invalid says the trial could "
                         "not be run: give its score <= 0 (e.g. -1), or --valid")
    if not directory.is_dir():
        raise InputError("no pending trial: run `ltamp train SKILL --ask --out DIR` first",
                         location_in(directory))
    # The same lock as `ltamp train`: a tell never records its score under a running
    # trainer's model, and of two tells of one trial the second finds nothing pending.
    with exclusive_writer(directory, is_directory=True, wait=wait, option="DIR"):
        return _tell_locked(directory, score, valid, outcome, spec)


def _tell_locked(directory: Path, score: float, valid: bool,
                 outcome: Sequence[float] | None, declared: SkillSpec | None) -> TrialRecord:
    pending = _read_pending(directory)
    if not np.isfinite(score):
        raise InputError(f"--score: expected a finite number, got {score}")
    spec = checked_spec(pending["spec"])
    config = LearningConfig(**pending["config"])
    proposal = Proposal(**pending["proposal"])
    if declared is None and (outcome is not None or pending.get("has_outcome") is True):
        declared = backend_spec(proposal.backend, proposal.skill)
    if declared is not None and spec_to_json(declared) == spec_to_json(spec):
        spec = declared  # the same skill, with its outcome (code) if it declares one
    record = replace(_pending_record(spec, proposal), score=float(score), valid=bool(valid),
                     info={"strategy": config.strategy, "source": "tell"})
    if outcome is not None:
        if spec.outcome is None:
            raise InputError(f"--outcome: skill {spec.name!r} of backend "
                             f"{proposal.backend!r} declares no outcome (or its backend "
                             "cannot be loaded here)")
        if valid:
            try:
                values = checked_outcome(spec, np.asarray(record.context),
                                         np.asarray(record.control), float(score), outcome)
            except ValueError as error:
                raise InputError(f"--outcome: {error}") from None
            record = replace(record, outcome=values)
    dataset = TrialDataset(directory / TRIALS_FILE)
    records = dataset.read()
    # A crash between appending and clearing pending.json must not duplicate the trial; a
    # record of another trial under the proposal's index (a live run resumed in DIR since
    # the ask) must not pass for it: the told result would be dropped without a word.
    holder = next((r for r in records if r.index == proposal.index), None)
    if holder is None:
        dataset.append(record)
        records.append(record)
    elif (holder.seed, holder.context, holder.control) != (record.seed, record.context,
                                                          record.control):
        raise InputError(
            f"trial {proposal.index} is already recorded, and it is not the pending trial "
            "(another run appended its own trials since the ask): nothing was recorded; "
            "give this result to a fresh directory with `ltamp import`, or ask again",
            location_in(dataset.path))
    rng = np.random.default_rng([config.seed, len(records), 11])
    x, y = learner_from_records(spec, config, records, rng).training_set()
    model = fit_model(spec, config, x, y, _previous_model(directory), rng=rng,
                      n_trials=len(records))
    model.save(
        str(directory),
        backend=proposal.backend,
        strategy=config.strategy,
        training={
            "mode": "ask-tell",
            "n_trials": len(records),
            "n_valid": sum(r.valid for r in records),
            "n_success": sum(is_success(r) for r in records),
            "init": config.init,
            "seed": config.seed,
            "trials_file": TRIALS_FILE,
            **training_metadata(spec, config),
        },
    )
    (directory / PENDING_FILE).unlink()
    return record
