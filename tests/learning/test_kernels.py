"""Kernels against independent references: GPy's MLP kernel and gpytorch's RBF/Matérn."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from ltamp_cli.learning.kernels import arcsine, matern52, rbf

gpytorch = pytest.importorskip("gpytorch")
from ltamp_cli.learning.gpytorch_kernels import ArcsineKernel, to_gpytorch  # noqa: E402


@pytest.fixture
def points() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(3)
    return rng.uniform(-1, 1, (7, 4)), rng.uniform(-1, 1, (5, 4))


def test_arcsine_matches_gpy_mlp_with_ard(points):
    gpy = pytest.importorskip("GPy")
    x1, x2 = points
    weights = np.array([0.3, 2.0, 7.5, 0.05])
    for bias in (0.1, 1.0, 25.0):
        reference = gpy.kern.MLP(
            4, variance=1.7, weight_variance=weights, bias_variance=bias, ARD=True
        )
        ours = 1.7 * arcsine(
            torch.as_tensor(x1), torch.as_tensor(x2), torch.as_tensor(weights), torch.tensor(bias)
        )
        np.testing.assert_allclose(
            ours.numpy(), reference.K(x1, x2), rtol=1e-7
        )  # GPy round-trips parameters through softplus
        diag = 1.7 * arcsine(
            torch.as_tensor(x1), None, torch.as_tensor(weights), torch.tensor(bias), diag=True
        )
        np.testing.assert_allclose(diag.numpy(), reference.Kdiag(x1), rtol=1e-7)


def test_gpytorch_arcsine_kernel_equals_function_and_gpy(points):
    gpy = pytest.importorskip("GPy")
    x1, x2 = points
    kernel = ArcsineKernel(ard_num_dims=4).double()
    kernel.weight_variance = torch.tensor([0.5, 1.5, 3.0, 0.2], dtype=torch.float64)
    kernel.bias_variance = 0.7
    with torch.no_grad():
        dense = kernel(torch.as_tensor(x1), torch.as_tensor(x2)).to_dense().numpy()
    reference = gpy.kern.MLP(
        4, variance=1.0, weight_variance=[0.5, 1.5, 3.0, 0.2], bias_variance=0.7, ARD=True
    )
    np.testing.assert_allclose(dense, reference.K(x1, x2), rtol=1e-7)


@pytest.mark.parametrize("name", ["rbf", "matern52", "mlp"])
def test_to_gpytorch_reproduces_our_kernels(points, name):
    x1, x2 = (torch.as_tensor(p) for p in points)
    params = torch.tensor(
        [0.4, 1.1, 2.5, 0.8, 1.3][: 5 if name == "mlp" else 4], dtype=torch.float64
    )
    if name == "rbf":
        ours = rbf(x1, x2, params)
    elif name == "matern52":
        ours = matern52(x1, x2, params)
    else:
        ours = arcsine(x1, x2, params[:-1], params[-1])
    kernel = to_gpytorch(name, params, outputscale=2.0)
    with torch.no_grad():
        theirs = kernel(x1, x2).to_dense()
    np.testing.assert_allclose(2.0 * ours.numpy(), theirs.numpy(), rtol=1e-6)
    assert isinstance(kernel, gpytorch.kernels.ScaleKernel)


@pytest.mark.parametrize("name", ["rbf", "matern52", "mlp"])
def test_covariance_is_positive_semidefinite_with_matching_diagonal(name):
    x = torch.as_tensor(np.random.default_rng(0).uniform(-1, 1, (40, 3)))
    params = torch.tensor([0.5, 2.0, 1.0, 0.3][: 4 if name == "mlp" else 3], dtype=torch.float64)
    from ltamp_cli.learning.kernels import unit_kernel

    full = unit_kernel(name, x, x, params)
    np.testing.assert_allclose(
        full.diagonal().numpy(), unit_kernel(name, x, x, params, diag=True).numpy(), rtol=1e-9
    )
    assert torch.linalg.eigvalsh(full).min() > -1e-9
    assert torch.allclose(full, full.T)
