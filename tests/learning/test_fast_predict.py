"""The no-autograd prediction path equals the differentiable one (issue #4 speed work)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from ltamp_cli.learning.gp import DTYPE, GaussianProcess
from ltamp_cli.learning.kernels import KERNEL_NAMES, CrossCovariance, unit_kernel


def _gp(kernel: str, noise: float, seed: int = 0) -> GaussianProcess:
    """A GP with fixed, deliberately uneven hyperparameters (no fit: fast and exact)."""
    rng = np.random.default_rng(seed)
    dim = 5
    x = rng.uniform(-1, 1, (120, dim))
    y = np.sin(3 * x[:, 0]) + x[:, 1] * x[:, 2] - 0.2
    k = dim + 1 if kernel == "mlp" else dim
    params = rng.uniform(np.log(0.2), np.log(3.0), k)
    theta = np.concatenate([params, [np.log(1.7), np.log(noise), 0.1]])
    return GaussianProcess(kernel, x, y, theta, y_scale=1.0)


@pytest.mark.parametrize("kernel", KERNEL_NAMES)
def test_cross_covariance_equals_unit_kernel(kernel: str) -> None:
    rng = np.random.default_rng(1)
    x_train = torch.as_tensor(rng.uniform(-1, 1, (40, 3)), dtype=DTYPE)
    query = torch.as_tensor(rng.uniform(-1.2, 1.2, (33, 3)), dtype=DTYPE)
    query[:5] = x_train[:5]  # r = 0 exactly: the Matérn square root and clamps
    params = torch.tensor([0.3, 1.1, 4.0, 0.7][: 4 if kernel == "mlp" else 3], dtype=DTYPE)
    cross = CrossCovariance(kernel, x_train, params)
    reference = unit_kernel(kernel, query, x_train, params).T
    buffers = torch.empty(40, 33, dtype=DTYPE), torch.empty(40, 33, dtype=DTYPE)
    for result in (cross.transposed(query), cross.transposed(query, *buffers)):
        assert result.shape == (40, 33)
        torch.testing.assert_close(result, reference, rtol=0.0, atol=1e-13)


@pytest.mark.parametrize("kernel", KERNEL_NAMES)
@pytest.mark.parametrize("noise", [1e-6, 1e-2])
def test_fast_posterior_matches_autograd_path(kernel: str, noise: float) -> None:
    gp = _gp(kernel, noise)
    rng = np.random.default_rng(2)
    # 1,203 candidates: several blocks plus a ragged last one; training points included,
    # where the variance is a small difference of large numbers.
    x = np.concatenate([rng.uniform(-1, 1, (1200, gp.dim)), gp.x_np[:3]])
    with torch.enable_grad():
        x_t = torch.as_tensor(x, dtype=DTYPE).requires_grad_(True)
        mean_ref, variance_ref = gp.posterior_torch(x_t)
    mean_ref, variance_ref = mean_ref.detach().numpy(), variance_ref.detach().numpy()
    mean, std = gp.predict(x)
    np.testing.assert_allclose(mean, mean_ref, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(std**2, variance_ref, rtol=1e-6, atol=1e-10 * 1.7)
    # Near the data the variance is about the noise, far from it about the prior.
    assert np.all(std[-3:] ** 2 < 10 * noise + 1e-9)
    with torch.no_grad():
        fast_mean, fast_variance = gp.posterior_torch(torch.as_tensor(x[:7], dtype=DTYPE))
    np.testing.assert_allclose(fast_mean.numpy(), mean_ref[:7], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(fast_variance.numpy(), variance_ref[:7], rtol=1e-6, atol=1e-10)


@pytest.mark.parametrize("count", [0, 1, 499, 500, 501])
def test_block_edges(count: int) -> None:
    gp = _gp("matern52", 1e-3)
    x = np.random.default_rng(3).uniform(-1, 1, (count, gp.dim))
    mean, std = gp.predict(x, chunk=500)
    assert mean.shape == std.shape == (count,)
    if count:
        single = np.array([gp.predict(row[None])[0][0] for row in x[-2:]])
        np.testing.assert_allclose(mean[-2:], single, rtol=1e-10, atol=1e-12)
