"""Trial files edited by hand or by other tools: each defect is one error line naming the
file and line (or the record), exit 2 through ``ltamp train --data``, and the same refusal
from the Python API. Before the fix, NaN/Infinity and far-off values escaped as a
``CholeskyError`` traceback and ``"valid": "false"`` was read as a valid trial."""

from __future__ import annotations

import io
import json
import re
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig, learn_from_pool
from ltamp_cli.trials.record import TrialDataset, TrialRecord


def _good_lines(n: int = 12) -> list[str]:
    rng = np.random.default_rng(0)
    return [TrialRecord("moving2d", (float(rng.uniform(0, 1)),),
                        (float(rng.uniform(0, 4)), float(rng.uniform(-1, 1))),
                        float(rng.normal()), True, 100 + i, "synthetic", index=i).to_json()
            for i in range(n)]


def _edited(**fields: Any) -> str:
    record = json.loads(_good_lines(1)[0])
    record.update(fields, index=99)
    return json.dumps(record)


# label -> (bad last line, text expected in the error)
AT_LINE = {  # reported at file:13:1 while reading
    "NaN context": (_edited().replace('"context": [', '"context": [NaN, '), "finite"),
    "Infinity control": (_edited(control=[0.5, 7.0]).replace("7.0", "Infinity"), "finite"),
    "valid as a string": (_edited(valid="false"), "'valid' must be true or false"),
    "context as a string": (_edited(context="5"), "'context' must be a list"),
    "fractional seed": (_edited(seed=3.7), "'seed' must be an integer"),
    "a JSON string line": (json.dumps("skill context control score valid seed backend"),
                           "expected a JSON object"),
}
AGAINST_SKILL = {  # reported for the record once the skill is known
    "wrong context length": (_edited(context=[0.1, 0.2]), "context has 2 value(s)"),
    "control far outside the bounds": (_edited(control=[1e300, 0.0]), "far outside"),
    "huge score": (_edited(score=1e300), "beyond"),
}


def _train(path: Path, out: Path) -> tuple[int, list[str]]:
    stdout, stderr = io.StringIO(), io.StringIO()
    with redirect_stdout(stdout), redirect_stderr(stderr), pytest.raises(SystemExit) as done:
        main(["train", "moving2d", "--backend", "synthetic", "--data", str(path),
              "--out", str(out), "--budget", "12"])
    return int(done.value.code or 0), stderr.getvalue().strip().splitlines()


@pytest.mark.parametrize("label", sorted(AT_LINE))
def test_garbled_record_is_refused_at_its_line(tmp_path: Path, label: str) -> None:
    line, expected = AT_LINE[label]
    path = tmp_path / "trials.jsonl"
    path.write_text("\n".join([*_good_lines(), line]) + "\n")
    with pytest.raises(InputError, match=re.escape(expected)) as error:
        TrialDataset(path).read()
    assert f"{path}:13:1" in str(error.value)
    code, lines = _train(path, tmp_path / "model")
    assert code == 2 and len(lines) == 1 and f"{path}:13:1" in lines[0], lines
    assert not (tmp_path / "model" / "model.json").exists()


@pytest.mark.parametrize("label", sorted(AGAINST_SKILL))
def test_record_that_does_not_fit_the_skill_is_refused(tmp_path: Path, label: str) -> None:
    line, expected = AGAINST_SKILL[label]
    path = tmp_path / "trials.jsonl"
    path.write_text("\n".join([*_good_lines(), line]) + "\n")
    records = TrialDataset(path).read()
    backend = load_backend("synthetic")
    try:
        spec = backend.skills()["moving2d"]
    finally:
        backend.close()
    with pytest.raises(ValueError, match=re.escape(expected)):
        learn_from_pool(spec, records, LearningConfig(budget=13, seed=0))
    code, lines = _train(path, tmp_path / "model")
    assert code == 2 and len(lines) == 1 and expected in lines[0], lines


def test_good_file_still_trains(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    path.write_text("\n".join(_good_lines()) + "\n" + _good_lines(13)[-1][:30])  # torn tail
    code, lines = _train(path, tmp_path / "model")
    assert code == 0, lines
    assert json.loads((tmp_path / "model" / "model.json").read_text())["n_train"] == 12


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("evaluate") / "model"
    stdout, stderr = io.StringIO(), io.StringIO()
    with redirect_stdout(stdout), redirect_stderr(stderr), pytest.raises(SystemExit) as done:
        main(["train", "moving2d", "--strategy", "gp", "--budget", "8", "--init", "8",
              "--out", str(out)])
    assert not done.value.code, stderr.getvalue()
    return out


@pytest.mark.parametrize("label", sorted(AGAINST_SKILL))
def test_held_out_record_that_does_not_fit_the_skill_is_refused(tmp_path: Path, trained: Path,
                                                                label: str) -> None:
    """Round 5: `ltamp evaluate --data` (and `train --test-data`) did not check held-out
    records against the skill: a context of the wrong length was a numpy ValueError
    traceback ("inhomogeneous shape"), a control of 1e300 was scored without a word."""
    line, expected = AGAINST_SKILL[label]
    path = tmp_path / "test.jsonl"
    path.write_text("\n".join([*_good_lines(), line]) + "\n")
    stdout, stderr = io.StringIO(), io.StringIO()
    with redirect_stdout(stdout), redirect_stderr(stderr), pytest.raises(SystemExit) as done:
        main(["evaluate", str(trained), "--data", str(path), "--trials", "0"])
    lines = stderr.getvalue().strip().splitlines()
    assert done.value.code == 2 and len(lines) == 1 and expected in lines[0], lines
