"""Ask/tell trials carry the physics they were proposed for, and ``ask`` fits only on trials
``ltamp train`` would resume with.

Round 7: a proposal recorded the robot setup (round 6) but not the backend's physics tag, so
a told PyBullet scoop trial was written without ``physics`` and read as the engine's base
version ``pybullet@v1`` — the scoop runs ``pybullet@v1.1`` (50 solver iterations): a scoop
folder fed by ask/tell could never resume with live trials ("simulated with physics
pybullet@v1, not pybullet@v1.1"). And ``ask`` checked only the trials' skill: it fitted its
proposal on trials of another physics, setup or robot (which ``ltamp train`` on the same
folder refuses) and ``tell`` appended to that mix.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.ask_tell import ask, tell
from ltamp_cli.trials.record import TrialDataset, TrialRecord

from .test_physics_tags import _Tagged


@pytest.fixture(scope="module")
def bullet():  # type: ignore[no-untyped-def]
    backend = load_backend("pybullet")
    yield backend
    backend.close()


def test_a_told_scoop_trial_resumes_with_live_ones(tmp_path: Path, bullet) -> None:  # type: ignore[no-untyped-def]
    assert bullet.physics_tag("scoop") == "pybullet@v1.1"
    proposal = ask(bullet, "scoop", LearningConfig(budget=5, init=5, seed=0), tmp_path)
    assert proposal.physics == "pybullet@v1.1"
    pending = json.loads((tmp_path / "pending.json").read_text())
    assert pending["proposal"]["physics"] == "pybullet@v1.1"
    record = tell(tmp_path, -1.0)
    assert record.physics == "pybullet@v1.1"  # before: None, read as pybullet@v1
    dataset = TrialDataset(tmp_path / "trials.jsonl")
    # Live resumption (no trial is run: the budget is already met).
    result = learn_online(bullet, "scoop", LearningConfig(budget=1, init=5, seed=0), dataset)
    assert len(result.records) == 1  # before: InputError "pybullet@v1, not pybullet@v1.1"


def test_an_unversioned_backend_proposes_without_physics(tmp_path: Path) -> None:
    synthetic = load_backend("synthetic")
    proposal = ask(synthetic, "flick2d", LearningConfig(budget=5, init=5), tmp_path)
    assert proposal.physics is None and "physics" not in proposal.to_json()


def _record(physics: str | None, setup: str | None = None, backend: str = "pybullet",
            skill: str = "scoop") -> TrialRecord:
    return TrialRecord(skill=skill, context=(0.0,) * 4, control=(0.0,) * 4, score=-1.0,
                       valid=True, seed=1, backend=backend, index=0, setup=setup,
                       physics=physics)


@pytest.mark.parametrize(("stored", "words"), [
    (_record("pybullet@v1"), "physics pybullet@v1, not pybullet@v1.1"),
    (_record(None), "physics pybullet@v1, not pybullet@v1.1"),  # older, 5 iterations
    (_record("pybullet@v1.1", backend="pybullet+panda", setup="panda-r2"),
     "holds pybullet+panda trials, not pybullet"),
])
def test_ask_refuses_trials_train_would_refuse(tmp_path: Path, bullet, stored: TrialRecord,  # type: ignore[no-untyped-def]
                                                words: str) -> None:
    dataset = TrialDataset(tmp_path / "trials.jsonl")
    dataset.append(stored)
    config = LearningConfig(budget=5, init=5, seed=0)
    with pytest.raises((InputError, ValueError)) as live:
        learn_online(bullet, "scoop", config, dataset)
    assert words in str(live.value)
    with pytest.raises(InputError, match=words.replace("+", r"\+")):
        ask(bullet, "scoop", config, tmp_path)  # before: a proposal fitted on them
    assert not (tmp_path / "pending.json").exists()


def test_a_pending_proposals_odd_physics_is_corrupt(tmp_path: Path) -> None:
    synthetic = load_backend("synthetic")
    ask(synthetic, "flick2d", LearningConfig(budget=5, init=5), tmp_path)
    path = tmp_path / "pending.json"
    data = json.loads(path.read_text())
    data["proposal"]["physics"] = 5
    path.write_text(json.dumps(data))
    with pytest.raises(InputError, match=r"corrupt pending trial .*'physics'"):
        tell(tmp_path, 1.0)


def test_a_plugin_tag_travels_through_ask_and_tell(tmp_path: Path) -> None:
    tagged = _Tagged("slide@v2")
    assert ask(tagged, "flick2d", LearningConfig(budget=5, init=5), tmp_path).physics \
        == "slide@v2"
    assert tell(tmp_path, 0.5).physics == "slide@v2"
    with pytest.raises(InputError, match="physics slide@v2, not unversioned"):
        ask(load_backend("synthetic"), "flick2d", LearningConfig(budget=5, init=5), tmp_path)
