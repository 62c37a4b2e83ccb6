"""Trials with the Panda in the loop say which robot setup produced them, and two setups
never share a file.

The Panda's setup (grasps, base placement, timing) has versions per skill
(``ROBOT_SETUP_VERSIONS``: pour 3, scoop 2, push 3, stir 4) and each changed the labels. Before
round 6, ``ltamp collect --robot panda`` records said only ``"backend": "pybullet+panda"``, so
a file collected with setup 2 was resumed, or trained on, with setup 3's trials appended.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.protocol import trial_setup
from ltamp_cli.backends.pybullet.skills.robot import ROBOT_SETUP_VERSIONS
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.seeds import usable_seed
from ltamp_cli.trials.collect import CollectJob, collect, run_one, trial_seed
from ltamp_cli.trials.record import TrialDataset, TrialRecord

POUR_CONTEXT = (0.2, 0.08, 0.12, 0.07, 0.1, 0.06)
POUR_CONTROL = (-2.0, 0.0, 0.0, 0.1, 0.05)


def _cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str]:
    with pytest.raises(SystemExit) as done:
        main(list(args))
    return int(done.value.code or 0), capsys.readouterr().err


def _panda_record(index: int, setup: str | None) -> TrialRecord:
    """Trial ``index`` of ``ltamp collect pour --robot panda`` (seed 0) as another setup
    recorded it (its seed is the job's: only the setup differs)."""
    return TrialRecord(skill="pour", context=POUR_CONTEXT, control=POUR_CONTROL, score=-1.0,
                       valid=True, seed=trial_seed(usable_seed(0), index),
                       backend="pybullet+panda", index=index, setup=setup)


def test_the_backend_names_each_skills_setup() -> None:
    free, panda = load_backend("pybullet"), load_backend("pybullet", robot="panda")
    try:
        for skill, version in ROBOT_SETUP_VERSIONS.items():
            assert trial_setup(free, skill) is None
            assert trial_setup(panda, skill) == f"panda-r{version}"
        with pytest.raises(KeyError):
            trial_setup(panda, "juggle")
    finally:
        free.close()
        panda.close()


def test_a_robot_record_carries_its_setup(tmp_path: Path) -> None:
    # Trial 0 of seed 0 through the collection path (its drawn control fails the geometric
    # pre-check, so no world is built: cheap).
    backend = load_backend("pybullet", robot="panda")
    try:
        record = run_one(backend, CollectJob(skill="pour", backend="pybullet", n=1,
                                             robot="panda"), 0)
    finally:
        backend.close()
    assert record.setup == f"panda-r{ROBOT_SETUP_VERSIONS['pour']}"
    line = json.loads(record.to_json())
    assert line["setup"] == record.setup and TrialRecord.from_dict(line) == record
    # free-floating and other backends' records are written as before: no "setup" field
    free = TrialRecord(skill="pour", context=POUR_CONTEXT, control=POUR_CONTROL, score=-1.0,
                       valid=True, seed=0, backend="pybullet", index=0)
    assert "setup" not in json.loads(free.to_json())
    with pytest.raises(TypeError, match="setup"):
        TrialRecord.from_dict({**line, "setup": 3})


@pytest.mark.parametrize("old", [None, "panda-r2"])
def test_collect_refuses_a_file_of_another_setup(tmp_path: Path, old: str | None,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "pour.jsonl"
    TrialDataset(out).append(_panda_record(0, old))
    before = out.read_bytes()
    code, err = _cli(capsys, "collect", "pour", "-n", "2", "--out", str(out), "--backend",
                     "pybullet", "--robot", "panda")
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    said = "no recorded setup" if old is None else f"setup '{old}'"
    assert f"{out}:1: " in err and said in err and "not setup 'panda-r3'" in err, err
    assert out.read_bytes() == before  # nothing appended
    with pytest.raises(InputError, match="not setup 'panda-r3'"):  # the API's limit too
        collect(CollectJob(skill="pour", backend="pybullet", n=2, robot="panda"), out)


def test_training_refuses_trials_of_another_setup(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    model = tmp_path / "model"
    TrialDataset(model / "trials.jsonl").append(_panda_record(0, None))
    code, err = _cli(capsys, "train", "pour", "--backend", "pybullet", "--robot", "panda",
                     "--budget", "2", "--init", "2", "--out", str(model))
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "no recorded setup, not setup 'panda-r3'" in err, err
    assert len(TrialDataset(model / "trials.jsonl").read()) == 1
    backend = load_backend("pybullet", robot="panda")
    try:
        with pytest.raises(ValueError, match="not setup 'panda-r3'"):
            learn_online(backend, "pour", LearningConfig(budget=2, init=2),
                         TrialDataset(model / "trials.jsonl"))
    finally:
        backend.close()


class _OddSetupBackend:
    """A plugin whose ``trial_setup`` answers something that is not a setup name."""

    name = "odd"

    def __init__(self, answer: object) -> None:
        self.answer = answer

    def trial_setup(self, skill: str) -> object:
        if isinstance(self.answer, Exception):
            raise self.answer
        return self.answer


@pytest.mark.parametrize("answer", ["", "  ", 3, ["r1"], RuntimeError("no robot file")])
def test_a_plugins_bad_setup_is_one_line(answer: object) -> None:
    with pytest.raises(InputError, match="trial_setup"):
        trial_setup(_OddSetupBackend(answer), "pour")  # type: ignore[arg-type]


def test_a_plugin_without_setups_writes_none() -> None:
    assert trial_setup(_OddSetupBackend(None), "pour") is None  # type: ignore[arg-type]
    assert trial_setup(object(), "pour") is None  # type: ignore[arg-type]


def test_ask_and_tell_record_the_setup_they_proposed_for(tmp_path: Path) -> None:
    from ltamp_cli.learning.ask_tell import ask, tell

    backend = load_backend("pybullet", robot="panda")
    try:
        config = LearningConfig(budget=5, init=5, seed=0)
        proposal = ask(backend, "pour", config, tmp_path)
        assert proposal.setup == "panda-r3" and proposal.to_json()["setup"] == "panda-r3"
        record = tell(tmp_path, -1.0)
        assert record.setup == "panda-r3"
        # the told trial resumes with live Panda trials of the same setup (it was refused
        # as "no recorded setup" while proposals did not carry it)
        result = learn_online(backend, "pour", LearningConfig(budget=1, init=5, seed=0),
                              TrialDataset(tmp_path / "trials.jsonl"))
        assert len(result.records) == 1
    finally:
        backend.close()
    free = load_backend("pybullet")
    try:
        assert "setup" not in ask(free, "pour", LearningConfig(budget=5, init=5),
                                  tmp_path / "free").to_json()
    finally:
        free.close()
