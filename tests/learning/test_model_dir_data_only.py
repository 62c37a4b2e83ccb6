"""Model directories are data: no unpickling, exact predictions, hostile files rejected."""

from __future__ import annotations

import hashlib
import json
import pickle
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.learning.baselines import SKLEARN_KINDS, SklearnModel
from ltamp_cli.learning.gp import fit_gp
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.learning.model_dir import load_model, save_model


class _Payload:
    """Unpickling this writes a marker file: proof that code ran."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (Path.write_text, (self.marker, "pwned"))


def _fitted(synthetic, kind: str) -> SklearnModel:
    spec = synthetic.skills()["moving2d"]
    rng = np.random.default_rng(3)
    x = rng.uniform(-1, 1, size=(120, 3))
    y = np.sin(3 * x[:, 0]) + x[:, 1] - 0.2
    return SklearnModel.fit(spec, kind, x, y, seed=1)


@pytest.mark.parametrize("kind", SKLEARN_KINDS)
def test_sklearn_models_reload_from_plain_arrays_with_identical_predictions(
        synthetic, kind, tmp_path):
    model = _fitted(synthetic, kind)
    save_model(model, tmp_path / kind)
    assert not list((tmp_path / kind).glob("*.pkl"))
    with np.load(tmp_path / kind / "weights.npz", allow_pickle=False) as weights:
        assert all(not weights[name].dtype.hasobject for name in weights.files)
    again = load_model(tmp_path / kind).model
    x = np.random.default_rng(4).uniform(-1.2, 1.2, size=(500, 3))
    np.testing.assert_array_equal(again.decision_normalized(x), model.decision_normalized(x))
    np.testing.assert_array_equal(again.confidence_normalized(x), model.confidence_normalized(x))


def test_a_pickle_in_a_model_directory_is_never_loaded(synthetic, tmp_path):
    model = _fitted(synthetic, "rf-c")
    save_model(model, tmp_path)
    marker = tmp_path / "marker"
    # An attacker replaces the weights by a pickle, as .npz or as the old weights.pkl, and
    # writes a matching digest.
    (tmp_path / "weights.npz").write_bytes(pickle.dumps(_Payload(marker)))
    metadata = json.loads((tmp_path / "model.json").read_text())
    metadata["weights_sha256"] = hashlib.sha256((tmp_path / "weights.npz").read_bytes()
                                                ).hexdigest()
    (tmp_path / "model.json").write_text(json.dumps(metadata))
    with pytest.raises(InputError):
        load_model(tmp_path)
    (tmp_path / "weights.npz").unlink()
    (tmp_path / "weights.pkl").write_bytes(pickle.dumps(_Payload(marker)))
    with pytest.raises(InputError, match="pickle"):
        load_model(tmp_path)
    # An object array inside a real .npz needs pickle to load: refused too.
    np.savez(tmp_path / "weights.npz", classes=np.array([_Payload(marker)], dtype=object))
    with pytest.raises(InputError):
        load_model(tmp_path)
    assert not marker.exists()


def _read_arrays(directory: Path) -> dict[str, np.ndarray]:
    with np.load(directory / "weights.npz") as weights:
        return {name: weights[name].copy() for name in weights.files}


def _write_arrays(directory: Path, **arrays: np.ndarray) -> None:
    np.savez(directory / "weights.npz", **arrays)
    metadata = json.loads((directory / "model.json").read_text())
    metadata.pop("weights_sha256")
    (directory / "model.json").write_text(json.dumps(metadata))


@pytest.mark.parametrize("hostile", ["nan", "inf", "short", "loop", "feature"])
def test_hostile_forest_arrays_are_one_input_error(synthetic, tmp_path, hostile):
    model = _fitted(synthetic, "rf-r")
    save_model(model, tmp_path)
    arrays = _read_arrays(tmp_path)
    if hostile == "nan":
        arrays["value"][3, 0] = np.nan
    elif hostile == "inf":
        arrays["threshold"][0] = np.inf
    elif hostile == "short":
        arrays["feature"] = arrays["feature"][:-1]
    elif hostile == "loop":
        arrays["children_left"][0] = 0  # the root points at itself
    else:
        arrays["feature"][0] = 99
    _write_arrays(tmp_path, **arrays)
    with pytest.raises(InputError, match=r"model\.json"):
        load_model(tmp_path)


@pytest.mark.parametrize("hostile", ["nan-x", "wrong-length", "theta"])
def test_hostile_gp_arrays_are_one_input_error(synthetic, tmp_path, hostile):
    spec = synthetic.skills()["moving2d"]
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, size=(12, 3))
    model = LevelSetModel(spec, fit_gp(x, x[:, 0] - 0.1, rng=rng))
    save_model(model, tmp_path)
    arrays = _read_arrays(tmp_path)
    if hostile == "nan-x":
        arrays["x"][0, 0] = np.nan
    elif hostile == "wrong-length":
        arrays["y"] = arrays["y"][:-2]
    else:
        arrays["theta"] = arrays["theta"][:2]
    _write_arrays(tmp_path, **arrays)
    with pytest.raises(InputError, match=r"model\.json"):
        load_model(tmp_path)


def test_deep_or_non_finite_model_json_is_one_input_error(tmp_path):
    (tmp_path / "model.json").write_text("[" * 5000 + "]" * 5000)
    with pytest.raises(InputError, match="nested deeper"):
        load_model(tmp_path)
    (tmp_path / "model.json").write_text('{"format": "ltamp-skill-model", "x": NaN}')
    with pytest.raises(InputError, match="invalid JSON"):
        load_model(tmp_path)
