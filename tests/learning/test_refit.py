"""``ltamp train --refit`` / :func:`ltamp_cli.learning.refit.refit_model_dir` (issue #21).

A model directory is a GP fitted on its own ``trials.jsonl``; refitting it must give exactly
the model a resumed ``ltamp train`` at the same budget gives (same trials, same final fit,
same random generator), keep the trainer's metadata, record the previous hyperparameters, and
turn a fit made without the lengthscale prior into today's default (MAP) fit.
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.learning.refit import refit_model_dir
from ltamp_cli.trials.record import TrialDataset


def run(capsys, *argv: str) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as done:
        main(list(argv))
    captured = capsys.readouterr()
    return int(done.value.code or 0), captured.out, captured.err


def _train(capsys, out, budget: int = 30) -> None:
    code, _, err = run(capsys, "train", "moving2d", "--backend", "synthetic", "--strategy",
                       "lse2", "--budget", str(budget), "--seed", "3", "--out", str(out))
    assert code == 0, err


def test_refit_equals_a_resumed_train_at_the_same_budget(capsys, tmp_path):
    trained = tmp_path / "trained"
    _train(capsys, trained)
    resumed, refitted = tmp_path / "resumed", tmp_path / "refitted"
    shutil.copytree(trained, resumed)
    shutil.copytree(trained, refitted)
    _train(capsys, resumed)  # 30 trials recorded already: no trial runs, only the final fit
    code, out, err = run(capsys, "train", "moving2d", "--out", str(refitted), "--refit",
                         "--json")
    assert code == 0, err
    summary = json.loads(out)
    assert summary["n_trials"] == 30
    expected = load_model(resumed).metadata["hyperparameters"]
    got = load_model(refitted).metadata
    np.testing.assert_allclose(got["hyperparameters"]["lengthscales"], expected["lengthscales"])
    assert got["hyperparameters"]["noise"] == pytest.approx(expected["noise"])
    assert summary["previous_hyperparameters"] == load_model(trained).metadata["hyperparameters"]
    # The trainer's metadata survives; the trials are untouched.
    before = load_model(trained).metadata
    assert got["strategy"] == "lse2" and got["training"] == before["training"]
    assert got["refit"]["previous_hyperparameters"] == before["hyperparameters"]
    assert ((refitted / "trials.jsonl").read_bytes() == (trained / "trials.jsonl").read_bytes())


def test_refit_turns_a_maximum_likelihood_fit_into_the_default_map_fit(tmp_path):
    backend = load_backend("synthetic")
    directory = tmp_path / "ml"
    config = LearningConfig(strategy="lse2", budget=25, seed=1, lengthscale_prior_sd=None)
    try:
        result = learn_online(backend, "moving2d", config, TrialDataset(directory / "trials.jsonl"))
    finally:
        backend.close()
    result.model.save(str(directory), backend="synthetic", strategy="lse2",
                      training={"n_trials": 25, "seed": 1, "init": 10,
                                "trials_file": "trials.jsonl"})
    ml = load_model(directory).metadata["hyperparameters"]
    map_fit = refit_model_dir(directory).metadata
    back = refit_model_dir(directory, lengthscale_prior_sd=None).metadata
    assert map_fit["refit"]["lengthscale_prior_sd"] == 1.0
    # Without the prior the refit is the stored ML fit again (same data, same starts) ...
    np.testing.assert_allclose(back["hyperparameters"]["lengthscales"], ml["lengthscales"],
                               rtol=1e-4)
    # ... and the prior moved it: the default fit is not the old one.
    assert not np.allclose(map_fit["hyperparameters"]["lengthscales"], ml["lengthscales"],
                           rtol=1e-3)


def test_refit_refuses_a_directory_without_its_trials(capsys, tmp_path):
    trained = tmp_path / "m"
    _train(capsys, trained, budget=12)
    (trained / "trials.jsonl").unlink()
    with pytest.raises(InputError, match="no trials file"):
        refit_model_dir(trained)
    code, out, err = run(capsys, "train", "moving2d", "--out", str(trained), "--refit")
    assert code == 2 and not out
    assert len(err.strip().splitlines()) == 1 and "no trials file" in err
    code, _, err = run(capsys, "train", "toy1d", "--out", str(tmp_path / "none"), "--refit")
    assert code == 2 and len(err.strip().splitlines()) == 1


def test_refit_refuses_another_skill_and_pool_options(capsys, tmp_path):
    trained = tmp_path / "m"
    _train(capsys, trained, budget=12)
    code, _, err = run(capsys, "train", "toy1d", "--out", str(trained), "--refit")
    assert code == 2 and "not 'toy1d'" in err
    code, _, err = run(capsys, "train", "moving2d", "--out", str(trained), "--refit",
                       "--data", str(trained / "trials.jsonl"))
    assert code == 2 and "--refit" in err
