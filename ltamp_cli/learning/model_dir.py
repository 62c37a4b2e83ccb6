"""The saved-model directory: ``model.json`` (metadata) + weights; reloads without retraining.

Layout of ``DIR/``:

* ``model.json`` — ``format`` (``"ltamp-skill-model"``), ``version``, ``kind`` (``gp``,
  ``nn-c``, ``nn-r``, ``rf-c``, ``rf-r``, ``random``), ``skill`` (the full
  :class:`~ltamp_cli.backends.protocol.SkillSpec`), ``input_order`` (GP input names, controls
  first), ``normalization`` (physical box mapped to ``[-1, 1]``), ``kernel`` and
  ``hyperparameters`` (GP), ``data_candidates`` (GP: θ* also tries the training controls, as
  for a skill whose trials were relabelled by their outcome), plus whatever the trainer adds
  (``backend``, ``strategy``, ``training`` — trial counts, the trials file and
  ``hindsight``, the relabelling used or ``null`` —, ``beta`` …).
* ``weights.npz`` — GP: training inputs ``x`` (normalised) and scores ``y``, log
  hyperparameters ``theta``, score scale (no pickle); ``random``: the mean score.
  scikit-learn baselines: the fitted trees or layer weights as plain arrays
  (:mod:`.estimator_arrays`), their activations under ``estimator`` in ``model.json``.
* ``trials.jsonl`` — the trials the model was trained on, when the trainer ran them.

A model directory is data, never code: nothing is unpickled (``np.load`` runs with
``allow_pickle=False``), and every array is checked for dtype, shape and finiteness before use,
so a crafted directory gives one ``InputError`` line, never a payload or a traceback.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import io
import json
import math
import os
import threading
import time
import zipfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from datetime import UTC, datetime
from importlib import metadata as package_metadata
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from ltamp_cli.backends.protocol import ParamSpace, SkillSpec
from ltamp_cli.errors import InputError, location_in
from ltamp_cli.jsondata import read_json_data
from ltamp_cli.learning.baselines import SKLEARN_KINDS, RandomModel, SklearnModel
from ltamp_cli.learning.estimator_arrays import export_estimator, import_estimator
from ltamp_cli.learning.gp import KERNEL_NAMES, GaussianProcess, n_kernel_params
from ltamp_cli.learning.model import LevelSetModel, SkillModel
from ltamp_cli.learning.normalize import joint_space

# The prior means fit_gp knows (ltamp_cli.learning.gp): a fitted constant or zero.
MEAN_MODES = ("constant", "zero")

FORMAT = "ltamp-skill-model"
VERSION = 1
METADATA_FILE = "model.json"
# A reader racing a save (weights replaced, model.json not yet) retries this often, this long
# apart, before it reports the mismatch: the save's window is one digest and one small write.
_READ_ATTEMPTS = 6
_READ_RETRY_S = 0.05
# Saves hold this file's lock exclusively for their two renames and readers share it while
# they read both files, so that a reader never pairs one save's weights with another's
# model.json however fast saves follow each other (retries alone cannot promise that).
# Readers never create it (model folders may be read-only or shipped without it).
SWAP_LOCK_FILE = ".ltamp-swap.lock"


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
        "deterministic": spec.deterministic,
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
        deterministic=bool(data.get("deterministic", False)),
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
        # θ* also tries the training controls (relabelled skills): a reloaded model must
        # consider the same candidates as the one trained in memory
        record["data_candidates"] = bool(model.data_candidates)
        arrays: dict[str, Any] = dict(model.gp.state())
    elif isinstance(model, SklearnModel):
        record["constant"] = model.constant
        arrays, settings = (export_estimator(model.kind, model.estimator)
                            if model.estimator is not None else ({}, {}))
        record["estimator"] = settings if model.estimator is not None else None
    elif isinstance(model, RandomModel):
        arrays = {"mean_score": np.array(model.mean_score)}
    else:
        raise TypeError(f"cannot save a {type(model).__name__}")
    # Both files are written to temporaries first, then renamed over the old ones back to
    # back, weights first: a reader racing the save sees new weights beside the old metadata
    # only between two renames (it reads again, see load_model), and a save killed in between
    # leaves a mismatch that the digest exposes on load instead of mixing the two.
    weights = _write_temporary(directory / "weights.npz",
                               lambda handle: np.savez(handle, **arrays))
    try:
        record["weights_sha256"] = _sha256(weights)
        record.update(metadata)
        text = json.dumps(record, indent=2, sort_keys=True, allow_nan=False) + "\n"
        meta = _write_temporary(directory / METADATA_FILE,
                                lambda handle: handle.write(text.encode()))
        try:
            with _swap_lock(directory, fcntl.LOCK_EX, create=True):
                weights.replace(directory / "weights.npz")
                meta.replace(directory / METADATA_FILE)
        finally:
            meta.unlink(missing_ok=True)
    finally:
        weights.unlink(missing_ok=True)
    return directory


def _write_temporary(path: Path, write: Callable[[BinaryIO], Any]) -> Path:
    """Write a temporary file beside ``path`` (a name of this process and thread: two savers
    never share one) and return its path."""
    temporary = path.with_name(f"{path.name}.{os.getpid()}-{threading.get_ident()}.tmp")
    try:
        with temporary.open("wb") as handle:
            write(handle)
    except OSError as error:  # a full disk, a file size limit: no temporary left behind
        temporary.unlink(missing_ok=True)
        raise InputError(f"{path.parent}: could not save the model ({path.name}: "
                         f"{error.strerror or error}); the directory is unchanged") from None
    return temporary


@contextlib.contextmanager
def _swap_lock(directory: Path, operation: int, *, create: bool) -> Iterator[None]:
    """Hold ``directory``'s swap lock (``fcntl.LOCK_EX`` or ``LOCK_SH``) for the body; without
    a lock file (or one that cannot be opened) the body runs unlocked: readers then rely on
    their retries, as for folders written before the lock existed."""
    flags = os.O_RDONLY | (os.O_CREAT if create else 0)
    try:
        fd = os.open(directory / SWAP_LOCK_FILE, flags, 0o644)
    except OSError:
        yield
        return
    try:
        fcntl.flock(fd, operation)
        yield
    finally:
        os.close(fd)


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _weights_bytes(directory: Path) -> bytes | None:
    """The bytes of ``weights.npz``, read once (``None`` when it is no regular file). The
    arrays are then taken from these bytes, not from a second read that another save could
    have replaced in between."""
    weights = directory / "weights.npz"
    return weights.read_bytes() if weights.is_file() else None


def _matches(metadata: dict[str, Any], data: bytes | None) -> bool:
    """Whether ``data`` are the weights ``model.json`` was saved with (``True`` when it
    predates digests and so cannot tell)."""
    expected = metadata.get("weights_sha256")
    if expected is None:
        return True
    return hashlib.sha256(data if data is not None else b"").hexdigest() == expected


def load_metadata(directory: str | Path) -> dict[str, Any]:
    """``model.json`` of a model directory, checked for its format and version only (not
    its weights: :func:`load_model` checks those). Bad input raises ``InputError``."""
    directory = Path(directory)
    path = directory / METADATA_FILE
    if not path.is_file():
        raise InputError(
            f"no {METADATA_FILE} here: not an ltamp model directory", location_in(directory)
        )
    metadata = read_json_data(path)
    if not isinstance(metadata, dict) or metadata.get("format") != FORMAT:
        raise InputError(f"not an ltamp model (expected format {FORMAT!r})", location_in(path))
    if metadata.get("version") != VERSION:
        raise InputError(
            f"unsupported model version {metadata.get('version')!r}", location_in(path)
        )
    return metadata


def load_model(directory: str | Path) -> LoadedModel:
    """Read a model directory written by :func:`save_model`; bad input raises ``InputError``.

    Data only: the weights are read with ``allow_pickle=False`` and validated (dtype, shape,
    finite values) before any model is built from them.
    """
    directory = Path(directory)
    path = directory / METADATA_FILE
    data: bytes | None = None
    for attempt in range(_READ_ATTEMPTS):
        with _swap_lock(directory, fcntl.LOCK_SH, create=False):
            metadata = load_metadata(directory)
            if ((directory / "weights.pkl").exists()
                    and not (directory / "weights.npz").exists()):
                raise InputError("weights.pkl is a pickle, which ltamp no longer loads (it can "
                                 "run code): train the model again to write weights.npz",
                                 location_in(path))
            # Without the swap lock another process may be saving this directory (new
            # weights renamed in, model.json next): the weights read on the previous attempt
            # often belong to the model.json read now, so they are tried before reading the
            # weights again.
            if attempt > 0 and _matches(metadata, data):
                break
            data = _weights_bytes(directory)
            if _matches(metadata, data):
                break
        if attempt + 1 == _READ_ATTEMPTS:  # a save interrupted for good
            raise InputError(f"weights.npz does not match {METADATA_FILE} (a save was "
                             "interrupted?): train again to rewrite the model", location_in(path))
        time.sleep(_READ_RETRY_S)
    try:
        spec = checked_spec(metadata["skill"])
        kind = metadata["kind"]
        weights = _read_arrays(io.BytesIO(data) if data is not None
                               else directory / "weights.npz")
        dim = spec.context.dim + spec.control.dim
        if kind == "gp":
            data_candidates = metadata.get("data_candidates", False)
            if not isinstance(data_candidates, bool):
                raise ValueError(f"'data_candidates' must be true or false, not "
                                 f"{data_candidates!r:.40}")
            model: SkillModel = LevelSetModel(spec, _gaussian_process(metadata, weights, dim),
                                              data_candidates)
        elif kind in SKLEARN_KINDS:
            settings = metadata.get("estimator")
            constant = _finite_number(metadata.get("constant", 0.0), "constant")
            if settings is None:
                model = SklearnModel(spec, kind, None, constant)
            else:
                if not isinstance(settings, dict):
                    raise ValueError("'estimator' must be an object")
                model = SklearnModel(spec, kind, import_estimator(kind, weights, settings, dim),
                                     constant)
        elif kind == "random":
            model = RandomModel(spec, _finite_number(_scalar(weights, "mean_score"),
                                                     "mean_score"))
        else:
            raise InputError(f"unknown model kind {kind!r}", location_in(path))
    except (KeyError, TypeError, ValueError, AttributeError, OSError, EOFError,
            zipfile.BadZipFile, RuntimeError) as error:
        raise InputError(
            f"incomplete or invalid model directory ({type(error).__name__}: {error})",
            location_in(path),
        ) from None
    return LoadedModel(model, metadata)


def _read_arrays(path: Path | BinaryIO) -> dict[str, np.ndarray]:
    """Every array of the ``.npz`` at ``path`` (or in a file object), refusing pickled
    (object) arrays."""
    with np.load(path, allow_pickle=False) as weights:
        arrays = {name: weights[name] for name in weights.files}
    for name, array in arrays.items():
        # complex numbers are numbers too, but casting them to float drops a part silently
        if array.dtype.hasobject or not (np.issubdtype(array.dtype, np.integer)
                                         or np.issubdtype(array.dtype, np.floating)
                                         or array.dtype == bool):
            raise ValueError(f"array {name!r} has dtype {array.dtype}, expected real numbers")
    return arrays


def _finite_number(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.number) \
            or not np.isfinite(value):
        raise ValueError(f"{name!r} must be a finite number, not {value!r}")
    return float(value)


def _scalar(arrays: dict[str, np.ndarray], name: str) -> float:
    if name not in arrays or arrays[name].shape != ():
        raise ValueError(f"array {name!r} must be a scalar")
    return float(arrays[name])


def checked_spec(data: Any) -> SkillSpec:
    """The skill of ``model.json``: names and finite ``low <= high`` bounds of equal length."""
    if not isinstance(data, dict):
        raise ValueError("'skill' must be an object")
    seen: set[str] = set()
    for part in ("context", "control"):
        space = data.get(part)
        if not isinstance(space, dict) or not all(
                isinstance(space.get(key), list) for key in ("names", "lows", "highs")):
            raise ValueError(f"skill {part!r} must hold lists 'names', 'lows' and 'highs'")
        lows = [_finite_number(v, f"{part} low") for v in space["lows"]]
        highs = [_finite_number(v, f"{part} high") for v in space["highs"]]
        if not len(space["names"]) == len(lows) == len(highs) or any(
                low > high for low, high in zip(lows, highs, strict=True)):
            raise ValueError(f"skill {part!r}: names, lows and highs must have equal lengths "
                             "and lows <= highs")
        # a width that overflows (-1e308 .. 1e308) normalises every value to inf or NaN
        if any(not math.isfinite(high - low) for low, high in zip(lows, highs, strict=True)):
            raise ValueError(f"skill {part!r}: every bound pair must have a finite width "
                             "(high - low)")
        for name in space["names"]:
            if not isinstance(name, str) or not name:
                raise ValueError(f"skill {part!r} names must be non-empty strings, not "
                                 f"{name!r:.40}")
            if name in seen:  # --context name=value would be ambiguous
                raise ValueError(f"skill {part!r}: the name {name!r:.40} is used twice")
            seen.add(name)
        units = space.get("units", [])
        if not isinstance(units, list) or not all(isinstance(u, str) for u in units):
            raise ValueError(f"skill {part!r} units must be a list of strings")
    # the skill's own fields keep their JSON types: "deterministic": "false" is no boolean
    # (bool("false") is True), "name": 5 no skill name
    if not isinstance(data.get("name"), str) or not data["name"]:
        raise ValueError(f"skill 'name' must be a non-empty string, not {data.get('name')!r:.40}")
    if not isinstance(data.get("description", ""), str):
        raise ValueError("skill 'description' must be a string")
    if not isinstance(data.get("deterministic", False), bool):
        raise ValueError(f"skill 'deterministic' must be true or false, not "
                         f"{data.get('deterministic')!r:.40}")
    _finite_number(data.get("invalid_score", -1.0), "invalid_score")
    return spec_from_json(data)


def _gaussian_process(metadata: dict[str, Any], arrays: dict[str, np.ndarray],
                      dim: int) -> GaussianProcess:
    """The GP of ``weights.npz``: ``x (n, dim)``, ``y (n,)``, ``theta`` finite."""
    kernel = metadata["kernel"]
    if kernel not in KERNEL_NAMES:
        raise ValueError(f"unknown kernel {kernel!r}")
    # theta of rbf and matern52 have the same length: a "kernel" edited by hand would
    # silently give other predictions from the same weights
    fitted = metadata["hyperparameters"].get("kernel", kernel)
    if fitted != kernel:
        raise ValueError(f"'kernel' is {kernel!r} but the hyperparameters were fitted with "
                         f"{fitted!r:.40}")
    mean_mode = metadata["hyperparameters"].get("mean_mode", "constant")
    if mean_mode not in MEAN_MODES:
        raise ValueError(f"'mean_mode' must be one of {', '.join(MEAN_MODES)}, not "
                         f"{mean_mode!r:.40}")
    for name in ("x", "y", "theta", "y_scale"):
        if name not in arrays:
            raise ValueError(f"missing array {name!r}")
        if not np.issubdtype(arrays[name].dtype, np.number):
            raise ValueError(f"array {name!r} must hold numbers")
        if not np.all(np.isfinite(arrays[name])):
            raise ValueError(f"array {name!r} holds NaN or infinite values")
    x, y, theta = arrays["x"], arrays["y"], arrays["theta"]
    if x.ndim != 2 or x.shape[1] != dim or y.shape != (len(x),):
        raise ValueError(f"arrays x {x.shape} and y {y.shape} must be (n, {dim}) and (n,)")
    expected = n_kernel_params(kernel, dim) + 3
    if theta.shape != (expected,):
        raise ValueError(f"array 'theta' has shape {theta.shape}, expected ({expected},)")
    if np.any(np.abs(theta[:-1]) > 50.0):
        raise ValueError("array 'theta' holds log hyperparameters beyond +-50")
    if arrays["y_scale"].shape != () or not float(arrays["y_scale"]) > 0.0:
        raise ValueError("'y_scale' must be a positive scalar")
    state = dict(arrays)
    state.setdefault("nll", np.array(float("nan")))
    return GaussianProcess.from_state(kernel, mean_mode, state)
