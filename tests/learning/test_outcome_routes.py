"""One model whatever the route (issue #21): a skill with an outcome is learned from its
trials' outcomes whether it is trained in memory, resumed, refitted (``--refit``), taught
through ask/tell or reloaded from disk; θ* of a reloaded model tries the same candidates.

The ``toss`` skill and backend are those of ``test_outcomes.py`` (a skill ltamp has never
seen: its context draws only goals near 1 m, so its own scores never show a far goal).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))

from test_outcomes import FAR_GOALS, TOSS, TossBackend, theta_star_lands

from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import (
    LearningConfig,
    learn_online,
    learner_from_records,
    training_metadata,
)
from ltamp_cli.learning.ask_tell import ask, tell
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.learning.refit import refit_model_dir
from ltamp_cli.trials.record import TrialDataset

CONFIG = LearningConfig(strategy="lse", budget=14, init=5, seed=3, hindsight_goals=2,
                        hindsight_cap=30)


def _train(directory: Path, config: LearningConfig = CONFIG):  # type: ignore[no-untyped-def]
    """Train toss live into ``directory`` and save it as ``ltamp train`` does."""
    directory.mkdir(parents=True, exist_ok=True)
    dataset = TrialDataset(directory / "trials.jsonl")
    result = learn_online(TossBackend(), "toss", config, dataset)
    result.model.save(str(directory), backend="toss-test", strategy=config.strategy,
                      training={"mode": "online", "n_trials": len(result.records),
                                "init": config.init, "seed": config.seed,
                                "trials_file": "trials.jsonl",
                                **training_metadata(TOSS, config)})
    return result, dataset


def test_refit_and_resume_fit_the_trials_and_their_relabelled_points(tmp_path: Path) -> None:
    result, dataset = _train(tmp_path / "m")
    trained = result.model
    n_trials = len(result.records)
    assert trained.gp.n > n_trials  # relabelled points besides the trials
    resumed = learn_online(TossBackend(), "toss", CONFIG, dataset).model  # no new trial
    refitted = refit_model_dir(tmp_path / "m", spec=TOSS)
    for model in (resumed, refitted.model):
        np.testing.assert_array_equal(model.gp.x_np, trained.gp.x_np)  # same data
        np.testing.assert_array_equal(model.gp.y_np, trained.gp.y_np)
    # refit = a resumed run's final fit: same generator, same data -> same hyperparameters
    np.testing.assert_allclose(refitted.model.gp.theta, resumed.gp.theta, rtol=1e-6)
    assert refitted.model.data_candidates and refitted.metadata["data_candidates"] is True
    assert refitted.metadata["training"]["hindsight"]["goals"] == 2
    # without the skill's outcome (the saved spec has none) the refit refuses, in one line
    with pytest.raises(InputError, match="outcome"):
        refit_model_dir(tmp_path / "m")


def test_refit_of_a_model_trained_without_outcomes_stays_on_scores(tmp_path: Path) -> None:
    config = LearningConfig(strategy="lse", budget=10, init=5, seed=3, hindsight=False)
    result, _ = _train(tmp_path / "m", config)
    refitted = refit_model_dir(tmp_path / "m", spec=TOSS).model
    assert refitted.gp.n == len(result.records) == 10
    assert not refitted.data_candidates


def test_reloaded_model_picks_the_same_theta_star(tmp_path: Path) -> None:
    result, _ = _train(tmp_path / "m")
    loaded = load_model(tmp_path / "m").model
    assert loaded.data_candidates is True  # type: ignore[attr-defined]
    np.testing.assert_allclose(theta_star_lands(loaded, FAR_GOALS),
                               theta_star_lands(result.model, FAR_GOALS), atol=1e-9)
    # a model.json with a non-boolean flag is refused like any bad field
    meta = json.loads((tmp_path / "m" / "model.json").read_text())
    meta["data_candidates"] = "yes"
    (tmp_path / "m" / "model.json").write_text(json.dumps(meta))
    with pytest.raises(InputError, match="data_candidates"):
        load_model(tmp_path / "m")


def test_ask_tell_learns_from_the_told_outcomes(tmp_path: Path) -> None:
    """Trials run outside ltamp with their outcome told: the far goals are learned (as in
    memory), the model holds the relabelled points, and a wrong outcome is refused."""
    backend, directory = TossBackend(), tmp_path / "at"
    config = LearningConfig(strategy="lse", budget=14, init=5, seed=1, hindsight_goals=2,
                            hindsight_cap=30)
    for _ in range(14):
        proposal = ask(backend, "toss", config, directory)
        result = backend.run_trial("toss", np.array(list(proposal.context.values())),
                                   np.array(list(proposal.control.values())), proposal.seed)
        if proposal.index == 13:  # an outcome that does not give the told score
            with pytest.raises(InputError, match="--outcome"):
                tell(directory, result.score, outcome=[result.outcome[0] + 1.0], spec=TOSS)
        tell(directory, result.score, outcome=list(result.outcome), spec=TOSS)
    records = TrialDataset(directory / "trials.jsonl").read()
    assert len(records) == 14 and all(r.outcome is not None for r in records)
    loaded = load_model(directory)
    assert loaded.metadata["training"]["hindsight"] is not None
    x, _ = learner_from_records(TOSS, config, records, np.random.default_rng(0)).training_set()
    np.testing.assert_array_equal(loaded.model.gp.x_np, x)  # type: ignore[attr-defined]
    lands = theta_star_lands(loaded.model, FAR_GOALS)
    assert (np.abs(lands - FAR_GOALS[:, 0]) < 0.5).sum() >= 2, lands


def test_tell_refuses_an_outcome_for_a_skill_without_one(tmp_path: Path) -> None:
    from ltamp_cli.backends import load_backend

    backend = load_backend("synthetic")
    ask(backend, "toy1d", LearningConfig(strategy="lse", budget=5, init=5), tmp_path)
    with pytest.raises(InputError, match="declares no outcome"):
        tell(tmp_path, 0.1, outcome=[1.0])
    tell(tmp_path, 0.1)  # scores only: as before


def test_the_first_init_trials_are_random_with_relabelling() -> None:
    """``init`` counts trials, not relabelled points: toss's drawn goals lie in [0.5, 1.5],
    the straddle's anywhere in [0, 10], so the first ``init`` trials must all lie there."""
    config = LearningConfig(strategy="lse", budget=12, init=8, seed=2, hindsight_goals=2,
                            hindsight_cap=30)
    goals = [r.context[0] for r in learn_online(TossBackend(), "toss", config).records]
    assert all(0.5 <= g <= 1.5 for g in goals[:8]), goals
    assert not all(0.5 <= g <= 1.5 for g in goals[8:]), goals  # then the straddle chooses


@pytest.mark.parametrize("with_outcomes", [False, True])
def test_refit_of_a_model_saved_before_training_hindsight(tmp_path: Path,
                                                          with_outcomes: bool) -> None:
    """``model.json`` without ``training.hindsight`` (saved before it existed): relabelled
    iff its trials carry outcomes (the shipped push's predate them and stay score-only)."""
    config = LearningConfig(strategy="lse", budget=10, init=5, seed=3, hindsight=False)
    _train(tmp_path / "m", config)
    meta = json.loads((tmp_path / "m" / "model.json").read_text())
    del meta["training"]["hindsight"]
    (tmp_path / "m" / "model.json").write_text(json.dumps(meta))
    if not with_outcomes:
        trials = tmp_path / "m" / "trials.jsonl"
        lines = [json.loads(line) for line in trials.read_text().splitlines()]
        trials.write_text("".join(json.dumps({k: v for k, v in line.items() if k != "outcome"})
                                  + "\n" for line in lines))
    refitted = refit_model_dir(tmp_path / "m", spec=TOSS).model
    assert (refitted.gp.n > 10) is with_outcomes
    assert refitted.data_candidates is with_outcomes
