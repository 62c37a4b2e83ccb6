"""Model directories crafted by hand: each defect is one ``InputError`` from
``load_model`` and, through the CLI, one stderr line and exit 2 (never samples at inf, never
a warning and exit 0)."""

from __future__ import annotations

import hashlib
import io
import json
from collections.abc import Callable, Iterator
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.learning.gp import fit_gp
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.learning.model_dir import load_model, save_model


def _metadata(directory: Path) -> dict[str, Any]:
    return json.loads((directory / "model.json").read_text())


def _write_metadata(directory: Path, metadata: dict[str, Any]) -> None:
    (directory / "model.json").write_text(json.dumps(metadata))


def _mutate_arrays(directory: Path, change: Callable[[dict[str, np.ndarray]], None]) -> None:
    with np.load(directory / "weights.npz", allow_pickle=False) as weights:
        arrays = {name: weights[name].copy() for name in weights.files}
    change(arrays)
    np.savez(directory / "weights.npz", **arrays)
    metadata = _metadata(directory)
    metadata["weights_sha256"] = hashlib.sha256(
        (directory / "weights.npz").read_bytes()).hexdigest()
    _write_metadata(directory, metadata)


def _huge_bounds(directory: Path) -> None:
    metadata = _metadata(directory)
    metadata["skill"]["control"]["lows"] = [-1e308, -1e308]
    metadata["skill"]["control"]["highs"] = [1e308, 1e308]
    _write_metadata(directory, metadata)


def _complex_x(directory: Path) -> None:
    _mutate_arrays(directory, lambda a: a.update(x=a["x"].astype(complex) + 1j))


def _names(names: list[Any]) -> Callable[[Path], None]:
    def mutate(directory: Path) -> None:
        metadata = _metadata(directory)
        metadata["skill"]["control"]["names"] = names
        _write_metadata(directory, metadata)
    return mutate


def _mean_mode(directory: Path) -> None:
    metadata = _metadata(directory)
    metadata["hyperparameters"]["mean_mode"] = "quadratic"
    _write_metadata(directory, metadata)


def _set(*path: str, value: Any) -> Callable[[Path], None]:
    """Set ``model.json``'s field at ``path`` to ``value`` (a hand edit)."""
    def mutate(directory: Path) -> None:
        metadata = _metadata(directory)
        target = metadata
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value
        _write_metadata(directory, metadata)
    return mutate


HOSTILE: dict[str, tuple[Callable[[Path], None], str]] = {
    # round 5 (before: loaded, and the first one predicted with another kernel's formula)
    "kernel edited (same theta length)": (_set("kernel", value="rbf"),
                                          "hyperparameters were fitted with 'matern52'"),
    "deterministic as a string": (_set("skill", "deterministic", value="false"),
                                  "'deterministic' must be true or false"),
    "skill name a number": (_set("skill", "name", value=5), "'name' must be a non-empty"),
    "description a list": (_set("skill", "description", value=[1]), "'description'"),
    "units not strings": (_set("skill", "control", "units", value=[1, 2]), "units"),
    "invalid score a success": (_set("skill", "invalid_score", value=5), "invalid_score"),
    "invalid score a string": (_set("skill", "invalid_score", value="x"), "invalid_score"),

    "bounds whose width overflows": (_huge_bounds, "finite width"),
    "complex weights": (_complex_x, "dtype complex"),
    "names that are not strings": (_names([1, None]), "names"),
    "duplicate names": (_names(["x", "phase"]), "twice"),
    "unknown mean mode": (_mean_mode, "mean_mode"),
}


@pytest.fixture
def model_dir(synthetic: Any, tmp_path: Path) -> Path:
    spec = synthetic.skills()["moving2d"]
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, size=(12, 3))
    save_model(LevelSetModel(spec, fit_gp(x, x[:, 0] - 0.1, rng=rng)), tmp_path / "m")
    load_model(tmp_path / "m")  # the unmodified directory loads
    return tmp_path / "m"


@pytest.fixture(scope="module")
def synthetic() -> Iterator[Any]:
    backend = load_backend("synthetic")
    yield backend
    backend.close()


@pytest.mark.parametrize("label", sorted(HOSTILE))
def test_hostile_model_dir_is_one_input_error(model_dir: Path, label: str) -> None:
    mutate, expected = HOSTILE[label]
    mutate(model_dir)
    with pytest.raises(InputError, match=expected):
        load_model(model_dir)
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["sample", str(model_dir), "--context", "phase=0.3", "-n", "3"])
    assert done.value.code == 2, (out.getvalue(), err.getvalue())
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("ltamp: error:"), lines
    assert expected in lines[0]
