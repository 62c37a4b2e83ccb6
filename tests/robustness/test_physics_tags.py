"""A plugin's physics tag and the records' ``physics``/``setup`` fields, read as data.

Round 7: ``backend_physics`` wrote ``str(physics_tag(skill))`` into every record, so a
plugin answering ``None`` (the protocol's "unversioned") recorded ``"physics": "None"`` and
then refused its own older files ("simulated with physics unversioned, not None"); an
answer of ``5`` or ``{}`` was recorded as text, ``""`` gave "physics unversioned, not
unversioned", and a raising ``physics_tag`` was a traceback. A record's empty
``"physics": ""``/``"setup": ""`` read the same contradictory way.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.trials.physics import backend_physics
from ltamp_cli.trials.record import TrialDataset

SKILL = "flick2d"


class _Tagged:
    """The synthetic backend with a plugin's ``physics_tag`` answering ``answer`` (raising
    it when it is an exception)."""

    def __init__(self, answer: object) -> None:
        self.inner = load_backend("synthetic")
        self.answer = answer

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)

    def physics_tag(self, skill: str) -> object:
        if isinstance(self.answer, BaseException):
            raise self.answer
        return self.answer


def _config(budget: int) -> LearningConfig:
    return LearningConfig(budget=budget, init=budget, seed=0)


def test_a_plugin_answering_none_is_unversioned(tmp_path: Path) -> None:
    dataset = TrialDataset(tmp_path / "trials.jsonl")
    plain = load_backend("synthetic")
    learn_online(plain, SKILL, _config(2), dataset)  # the plugin's release without the hook
    tagged = _Tagged(None)
    result = learn_online(tagged, SKILL, _config(3), dataset)  # before: refused
    assert len(result.records) == 3
    assert all(record.physics is None for record in result.records)  # before: "None"
    assert all("physics" not in json.loads(line) for line in
               dataset.path.read_text().splitlines())


@pytest.mark.parametrize("answer", [5, "", "  ", {"a": 1}, b"v1", RuntimeError("boom"),
                                    ValueError("no")])
def test_a_plugins_odd_physics_tag_is_one_line(tmp_path: Path, answer: object) -> None:
    with pytest.raises(InputError, match=r"physics_tag\('flick2d'\)"):
        backend_physics(_Tagged(answer), SKILL)
    dataset = TrialDataset(tmp_path / "trials.jsonl")
    with pytest.raises(InputError, match="physics_tag"):
        learn_online(_Tagged(answer), SKILL, _config(2), dataset)
    assert not dataset.path.exists() or not dataset.read()  # nothing recorded under it


def test_a_plugins_string_tag_is_recorded_as_is(tmp_path: Path) -> None:
    result = learn_online(_Tagged("slide@v2"), SKILL, _config(2),
                          TrialDataset(tmp_path / "t.jsonl"))
    assert [r.physics for r in result.records] == ["slide@v2", "slide@v2"]


def test_an_unknown_skill_stays_a_key_error() -> None:
    with pytest.raises(KeyError):
        backend_physics(_Tagged(KeyError("juggle")), "juggle")


@pytest.mark.parametrize("field", ["physics", "setup"])
@pytest.mark.parametrize("value", ["", " ", 5, True, ["pybullet@v1"], {"v": 1}])
def test_a_records_empty_or_odd_tag_is_located(tmp_path: Path, field: str,
                                                value: object) -> None:
    record = {"skill": SKILL, "context": [0.1], "control": [0.2, 0.3], "score": 1.0,
              "valid": True, "seed": 1, "backend": "synthetic", "index": 0, field: value}
    path = tmp_path / "t.jsonl"
    path.write_text(json.dumps(record) + "\n")
    with pytest.raises(InputError, match=rf"t.jsonl:1:1: .*field '{field}' must be a "
                                          "non-empty string or null"):
        TrialDataset(path).read()


def test_a_null_tag_reads_as_unrecorded(tmp_path: Path) -> None:
    record = {"skill": SKILL, "context": [0.1], "control": [0.2, 0.3], "score": 1.0,
              "valid": True, "seed": 1, "backend": "synthetic", "index": 0,
              "physics": None, "setup": None}
    path = tmp_path / "t.jsonl"
    path.write_text(json.dumps(record) + "\n")
    (read,) = TrialDataset(path).read()
    assert read.physics is None and read.setup is None
