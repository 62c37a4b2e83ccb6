"""Baselines (scikit-learn, random), the metrics and the model directory for every kind."""

from __future__ import annotations

import numpy as np
import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.baselines import RandomModel, SklearnModel
from ltamp_cli.learning.metrics import SkillEvaluator, f1_score
from ltamp_cli.learning.model_dir import load_model, save_model


def test_f1_score_by_hand():
    truth = np.array([1.0, 1.0, -1.0, -1.0, 0.5])
    decision = np.array([0.2, -0.1, 0.3, -2.0, 1.0])  # tp=2, fp=1, fn=1
    assert f1_score(truth, decision) == pytest.approx(2 * 2 / (2 * 2 + 1 + 1))
    assert f1_score(-np.ones(3), -np.ones(3)) == 1.0
    assert f1_score(np.ones(3), -np.ones(3)) == 0.0


@pytest.fixture(scope="module")
def evaluator(synthetic):
    return SkillEvaluator.synthetic(synthetic, "moving2d", n_test=2000, n_contexts=15, seed=7)


@pytest.mark.parametrize(
    ("kind", "min_f1"), [("rf-r", 0.6), ("rf-c", 0.4), ("nn-r", 0.4), ("nn-c", 0.3)]
)
def test_sklearn_baselines_learn_from_random_trials(synthetic, evaluator, kind, min_f1, tmp_path):
    result = learn_online(synthetic, "moving2d", LearningConfig(strategy=kind, budget=200, seed=0))
    model = result.model
    assert isinstance(model, SklearnModel) and model.kind == kind
    f1 = evaluator.heldout.f1(model)
    assert f1 > min_f1, f1
    assert evaluator.success_rate(model) >= 0.6
    save_model(model, tmp_path / kind, backend="synthetic")
    again = load_model(tmp_path / kind).model
    x = model.to_unit(evaluator.heldout.contexts[:50], evaluator.heldout.controls[:50])
    np.testing.assert_allclose(again.decision_normalized(x), model.decision_normalized(x))


def test_classifier_with_one_class_predicts_that_class(synthetic):
    spec = synthetic.skills()["moving2d"]
    model = SklearnModel.fit(spec, "nn-c", np.zeros((4, 3)), -np.ones(4))
    assert not model.predict_labels(np.array([0.5]), np.array([[2.0, 0.0]]))[0]


def test_random_baseline_is_worse_than_the_gp_and_proposes_valid_controls(
    synthetic, evaluator, tmp_path
):
    result = learn_online(
        synthetic, "moving2d", LearningConfig(strategy="random", budget=30, seed=0)
    )
    assert isinstance(result.model, RandomModel)
    assert evaluator.success_rate(result.model) < 0.5  # ~14% of the controls succeed
    gp = learn_online(synthetic, "moving2d", LearningConfig(strategy="gp", budget=30, seed=0)).model
    assert evaluator.success_rate(gp) > 0.8
    skill8d = synthetic.skills()["skill8d"]
    rng = np.random.default_rng(0)
    context = skill8d.context.sample_uniform(rng, 1)[0]
    theta, _ = RandomModel(skill8d, 0.0).most_confident_control(
        context, rng, lambda c, u: synthetic.is_valid("skill8d", c, u)
    )
    assert synthetic.is_valid("skill8d", context, theta[None, :])[0]
    save_model(result.model, tmp_path / "r")
    assert load_model(tmp_path / "r").model.mean_score == result.model.mean_score


def test_loading_a_non_model_directory_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match=r"model\.json"):
        load_model(tmp_path)
    (tmp_path / "model.json").write_text("{not json")
    with pytest.raises(InputError, match="invalid JSON"):
        load_model(tmp_path)
    (tmp_path / "model.json").write_text(
        '{"format": "ltamp-skill-model", "version": 1, "kind": "gp"}'
    )
    with pytest.raises(InputError, match="incomplete"):
        load_model(tmp_path)
