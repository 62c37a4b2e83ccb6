"""A model save killed between its two files is detected on load, never mixed silently."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.model_dir import load_model, save_model


def test_new_weights_beside_old_metadata_are_refused(synthetic, tmp_path):
    small = learn_online(synthetic, "moving2d", LearningConfig(strategy="gp", budget=12, seed=0))
    larger = learn_online(synthetic, "moving2d", LearningConfig(strategy="gp", budget=16, seed=0))
    first, second = tmp_path / "first", tmp_path / "second"
    save_model(small.model, first)
    save_model(larger.model, second)
    assert load_model(first).metadata["n_train"] == 12
    assert not list(first.glob("*.tmp"))
    # What a kill after the weights' rename and before model.json's would leave behind.
    (first / "weights.npz").write_bytes((second / "weights.npz").read_bytes())
    with pytest.raises(InputError, match=r"does not match model\.json"):
        load_model(first)
    # Saving again (what a resumed `ltamp train` does) repairs the directory.
    save_model(larger.model, first)
    reloaded = load_model(first).model
    x = np.zeros((3, 3))
    np.testing.assert_allclose(reloaded.decision_normalized(x),
                               larger.model.decision_normalized(x))


def test_models_saved_before_digests_still_load(synthetic, tmp_path):
    model = learn_online(synthetic, "moving2d", LearningConfig(strategy="gp", budget=12,
                                                               seed=1)).model
    save_model(model, tmp_path)
    record = json.loads((tmp_path / "model.json").read_text())
    del record["weights_sha256"]
    (tmp_path / "model.json").write_text(json.dumps(record))
    assert load_model(tmp_path).metadata["n_train"] == 12
