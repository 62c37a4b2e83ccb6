"""GP fitting, prediction, jitter fallback and the saved-model round trip."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from ltamp_cli.learning.gp import (
    CholeskyError,
    GaussianProcess,
    HyperBounds,
    fit_gp,
    robust_cholesky,
)
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.learning.model_dir import load_model


def _target(x: np.ndarray) -> np.ndarray:
    return np.sin(3.0 * x[:, 0]) + 0.5 * x[:, 1] ** 2 - 0.3


@pytest.mark.parametrize("kernel", ["rbf", "matern52", "mlp"])
def test_fit_interpolates_a_smooth_function_and_stays_in_bounds(kernel):
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (60, 3))  # the third input is irrelevant
    gp = fit_gp(x, _target(x), kernel, rng=rng)
    test = rng.uniform(-1, 1, (500, 3))
    mean, std = gp.predict(test)
    rmse = float(np.sqrt(np.mean((mean - _target(test)) ** 2)))
    assert rmse < 0.05, rmse
    assert np.all(std > 0)
    # ARD: the irrelevant input gets the longest lengthscale.
    assert int(np.argmax(gp.lengthscales)) == 2
    bounds = HyperBounds()
    low, high = (
        bounds.lengthscale
        if kernel != "mlp"
        else (bounds.weight_variance[1] ** -0.5, bounds.weight_variance[0] ** -0.5)
    )
    assert np.all(gp.lengthscales >= low * (1 - 1e-9)) and np.all(
        gp.lengthscales <= high * (1 + 1e-9)
    )


def test_posterior_matches_gpy_with_the_same_hyperparameters():
    gpy = pytest.importorskip("GPy")
    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, (30, 2))
    y = _target(np.c_[x, np.zeros(30)])
    gp = fit_gp(x, y, "mlp", rng=rng, mean="zero")
    weights, bias = gp.kernel_params[:-1], gp.kernel_params[-1]
    kern = gpy.kern.MLP(
        2, variance=gp.outputscale, weight_variance=weights, bias_variance=bias, ARD=True
    )
    reference = gpy.models.GPRegression(x, y[:, None], kern, noise_var=gp.noise)
    test = rng.uniform(-1, 1, (50, 2))
    ref_mean, ref_var = reference.predict_noiseless(test)
    mean, std = gp.predict(test)
    # GPy adds its own jitter when inverting, hence the loose absolute tolerance.
    np.testing.assert_allclose(mean, ref_mean[:, 0], rtol=1e-3, atol=2e-4)
    np.testing.assert_allclose(std**2, ref_var[:, 0], rtol=1e-2, atol=1e-5)


def test_chunked_prediction_equals_one_block():
    rng = np.random.default_rng(2)
    x = rng.uniform(-1, 1, (40, 2))
    gp = fit_gp(x, _target(np.c_[x, np.zeros(40)]), "matern52", rng=rng)
    test = rng.uniform(-1, 1, (2500, 2))
    a = gp.predict(test, chunk=1000)
    b = gp.predict(test, chunk=5000)
    np.testing.assert_allclose(a[0], b[0], rtol=1e-10)
    np.testing.assert_allclose(a[1], b[1], rtol=1e-8)


def test_jitter_fallback_rescues_a_singular_covariance():
    ones = torch.ones(5, 5, dtype=torch.float64)  # rank one: plain Cholesky fails
    assert int(torch.linalg.cholesky_ex(ones)[1]) != 0
    factor = robust_cholesky(ones)
    assert torch.allclose(factor @ factor.T, ones, atol=1e-5)
    with pytest.raises(CholeskyError):
        robust_cholesky(-torch.eye(3, dtype=torch.float64))


def test_duplicate_inputs_with_tiny_noise_still_fit():
    x = np.repeat(np.linspace(-1, 1, 8)[:, None], 3, axis=0)
    y = np.sin(3 * x[:, 0])
    gp = fit_gp(x, y, "rbf", bounds=HyperBounds(noise=(1e-12, 1e-10)))
    mean, _ = gp.predict(x[:8])
    np.testing.assert_allclose(mean, y[:8], atol=1e-3)


def test_with_data_keeps_hyperparameters_in_score_units():
    rng = np.random.default_rng(4)
    x = rng.uniform(-1, 1, (20, 2))
    y = _target(np.c_[x, np.zeros(20)])
    gp = fit_gp(x, y, "matern52", rng=rng)
    bigger = gp.with_data(np.r_[x, [[0.0, 0.0]]], np.r_[y, 5.0])
    assert math.isclose(bigger.outputscale, gp.outputscale, rel_tol=1e-9)
    assert math.isclose(bigger.noise, gp.noise, rel_tol=1e-9)
    np.testing.assert_allclose(bigger.lengthscales, gp.lengthscales)


def test_level_set_model_save_and_load_reproduce_predictions(tmp_path, synthetic, monkeypatch):
    spec = synthetic.skills()["moving2d"]
    rng = np.random.default_rng(5)
    contexts = spec.context.sample_uniform(rng, 30)
    controls = spec.control.sample_uniform(rng, 30)
    scores = synthetic.true_score("moving2d", contexts, controls)
    model = LevelSetModel(spec, fit_gp(_unit(spec, contexts, controls), scores, "mlp", rng=rng))
    model.save(str(tmp_path / "m"), backend="synthetic")
    # Reloading must not optimise hyperparameters again.
    monkeypatch.setattr(
        "ltamp_cli.learning.gp.minimize", lambda *a, **k: pytest.fail("refit on load")
    )
    loaded = LevelSetModel.load(str(tmp_path / "m"))
    probe_c = spec.context.sample_uniform(rng, 100)
    probe_u = spec.control.sample_uniform(rng, 100)
    np.testing.assert_allclose(
        loaded.predict(probe_c, probe_u)[0], model.predict(probe_c, probe_u)[0], rtol=1e-10
    )
    np.testing.assert_allclose(loaded.lengthscales, model.lengthscales)
    metadata = load_model(tmp_path / "m").metadata
    assert metadata["kernel"] == "mlp" and metadata["backend"] == "synthetic"
    assert metadata["input_order"] == ["x", "y", "phase"]
    assert metadata["normalization"]["lows"] == [0.0, -1.0, 0.0]


def _unit(spec, contexts, controls):
    from ltamp_cli.learning.normalize import BoxNormalizer, join_inputs, joint_space

    return BoxNormalizer.for_space(joint_space(spec)).to_unit(join_inputs(spec, contexts, controls))


def test_gaussian_process_rejects_bad_data():
    with pytest.raises(ValueError):
        fit_gp(np.zeros((3, 2)), np.array([0.0, np.nan, 1.0]))
    with pytest.raises(ValueError):
        fit_gp(np.zeros((3, 2)), np.zeros(2))
    assert GaussianProcess  # public name kept for the sampler work
