"""The saved-model directory: ``model.json`` (metadata) + weights; reloads without retraining.

Layout of ``DIR/``:

* ``model.json`` — ``format`` (``"ltamp-skill-model"``), ``version``, ``kind`` (``gp``,
  ``nn-c``, ``nn-r``, ``rf-c``, ``rf-r``, ``random``), ``skill`` (the full
  :class:`~ltamp_cli.backends.protocol.SkillSpec`), ``input_order`` (GP input names, controls
  first), ``normalization`` (physical box mapped to ``[-1, 1]``), ``kernel`` and
  ``hyperparameters`` (GP), plus whatever the trainer adds (``backend``, ``strategy``,
  ``training`` — trial counts and the trials file —, ``beta`` …).
* ``weights.npz`` — GP: training inputs ``x`` (normalised) and scores ``y``, log
  hyperparameters ``theta``, score scale (no pickle); ``random``: the mean score.
* ``weights.pkl`` — scikit-learn baselines (pickled estimator: load only trusted files).
* ``trials.jsonl`` — the trials the model was trained on, when the trainer ran them.
"""

from __future__ import annotations

import hashlib
import json
import pickle
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from importlib import metadata as package_metadata
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from ltamp_cli.backends.protocol import ParamSpace, SkillSpec
from ltamp_cli.errors import InputError, location_in
from ltamp_cli.learning.baselines import RandomModel, SklearnModel
from ltamp_cli.learning.gp import GaussianProcess
from ltamp_cli.learning.model import LevelSetModel, SkillModel
from ltamp_cli.learning.normalize import joint_space

FORMAT = "ltamp-skill-model"
VERSION = 1
METADATA_FILE = "model.json"


def space_to_json(space: ParamSpace) -> dict[str, Any]:
    data = {"names": list(space.names), "lows": list(space.lows), "highs": list(space.highs)}
    return {**data, "units": list(space.units)} if space.units else data


def space_from_json(data: dict[str, Any]) -> ParamSpace:
    return ParamSpace(
        tuple(map(str, data["names"])),
        tuple(map(float, data["lows"])),
        tuple(map(float, data["highs"])),
        tuple(map(str, data.get("units", ()))),
    )


def spec_to_json(spec: SkillSpec) -> dict[str, Any]:
    return {
        "name": spec.name,
        "description": spec.description,
        "invalid_score": spec.invalid_score,
        "context": space_to_json(spec.context),
        "control": space_to_json(spec.control),
    }


def spec_from_json(data: dict[str, Any]) -> SkillSpec:
    return SkillSpec(
        name=str(data["name"]),
        context=space_from_json(data["context"]),
        control=space_from_json(data["control"]),
        description=str(data.get("description", "")),
        invalid_score=float(data.get("invalid_score", -1.0)),
    )


def _package_version() -> str:
    try:
        return package_metadata.version("ltamp")
    except package_metadata.PackageNotFoundError:
        return "unknown"


@dataclass(frozen=True)
class LoadedModel:
    model: SkillModel
    metadata: dict[str, Any]


def save_model(model: SkillModel, directory: str | Path, **metadata: Any) -> Path:
    """Write ``model`` and ``metadata`` (JSON-able) into ``directory`` (created if needed)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    record: dict[str, Any] = {
        "format": FORMAT,
        "version": VERSION,
        "ltamp_version": _package_version(),
        "saved_at": datetime.now(UTC).isoformat(timespec="seconds"),
        "kind": model.kind,
        "skill": spec_to_json(model.spec),
        "input_order": list(joint_space(model.spec).names),
        "normalization": model.normalizer.to_json(),
    }
    if isinstance(model, LevelSetModel):
        record["kernel"] = model.kernel
        record["hyperparameters"] = model.gp.hyperparameters()
        record["n_train"] = model.gp.n
        weights_file = "weights.npz"
        _replace_atomically(directory / weights_file,
                            lambda handle: np.savez(handle, **model.gp.state()))
    elif isinstance(model, SklearnModel):
        record["constant"] = model.constant
        weights_file = "weights.pkl"
        _replace_atomically(directory / weights_file,
                            lambda handle: pickle.dump(model.estimator, handle))
    elif isinstance(model, RandomModel):
        weights_file = "weights.npz"
        _replace_atomically(directory / weights_file,
                            lambda handle: np.savez(handle, mean_score=np.array(model.mean_score)))
    else:
        raise TypeError(f"cannot save a {type(model).__name__}")
    # The weights are replaced before model.json: a save killed in between leaves new weights
    # beside the old metadata, which the digest exposes on load instead of mixing them.
    record["weights_sha256"] = _sha256(directory / weights_file)
    record.update(metadata)
    temporary = directory / (METADATA_FILE + ".tmp")
    temporary.write_text(json.dumps(record, indent=2, sort_keys=True, allow_nan=False) + "\n")
    temporary.replace(directory / METADATA_FILE)
    return directory


def _replace_atomically(path: Path, write: Callable[[BinaryIO], None]) -> None:
    """Write ``path`` through a temporary file in its directory, then rename it over."""
    temporary = path.with_name(path.name + ".tmp")
    with temporary.open("wb") as handle:
        write(handle)
    temporary.replace(path)


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _check_weights(directory: Path, metadata: dict[str, Any], path: Path) -> None:
    expected = metadata.get("weights_sha256")
    if expected is None:  # saved before digests were recorded
        return
    name = "weights.pkl" if metadata.get("kind") in ("nn-c", "nn-r", "rf-c", "rf-r") \
        else "weights.npz"
    weights = directory / name
    if not weights.is_file() or _sha256(weights) != expected:
        raise InputError(f"{name} does not match {METADATA_FILE} (a save was interrupted?): "
                         "train again to rewrite the model", location_in(path))


def load_model(directory: str | Path) -> LoadedModel:
    """Read a model directory written by :func:`save_model`; bad input raises ``InputError``."""
    directory = Path(directory)
    path = directory / METADATA_FILE
    if not path.is_file():
        raise InputError(
            f"no {METADATA_FILE} here: not an ltamp model directory", location_in(directory)
        )
    try:
        metadata = json.loads(path.read_text())
    except ValueError as error:
        raise InputError(f"invalid JSON: {error}", location_in(path)) from None
    if not isinstance(metadata, dict) or metadata.get("format") != FORMAT:
        raise InputError(f"not an ltamp model (expected format {FORMAT!r})", location_in(path))
    if metadata.get("version") != VERSION:
        raise InputError(
            f"unsupported model version {metadata.get('version')!r}", location_in(path)
        )
    _check_weights(directory, metadata, path)
    try:
        spec = spec_from_json(metadata["skill"])
        kind = metadata["kind"]
        if kind == "gp":
            with np.load(directory / "weights.npz") as weights:
                state = {name: weights[name] for name in weights.files}
            mean_mode = metadata["hyperparameters"].get("mean_mode", "constant")
            model: SkillModel = LevelSetModel(
                spec, GaussianProcess.from_state(metadata["kernel"], mean_mode, state)
            )
        elif kind in ("nn-c", "nn-r", "rf-c", "rf-r"):
            with (directory / "weights.pkl").open("rb") as handle:
                estimator = pickle.load(handle)
            model = SklearnModel(spec, kind, estimator, float(metadata.get("constant", 0.0)))
        elif kind == "random":
            with np.load(directory / "weights.npz") as weights:
                model = RandomModel(spec, float(weights["mean_score"]))
        else:
            raise InputError(f"unknown model kind {kind!r}", location_in(path))
    except (KeyError, TypeError, ValueError, OSError) as error:
        raise InputError(
            f"incomplete model directory ({type(error).__name__}: {error})", location_in(path)
        ) from None
    return LoadedModel(model, metadata)
