"""Covariance functions on normalised inputs (appendix A of the paper).

Each kernel is a pure torch function of the inputs and its *unit* hyperparameters (the signal
variance is applied by the GP), so that fitting can differentiate it cheaply;
:class:`ArcsineKernel` wraps the MLP kernel as a gpytorch ``Kernel`` for use in gpytorch/BoTorch
models, and :func:`to_gpytorch` builds the equivalent gpytorch kernel of any fitted GP.

Shapes: ``x1 (n, d)``, ``x2 (m, d)`` -> ``(n, m)``; with ``diag=True`` (``x1 is x2``) ``(n,)``.
"""

from __future__ import annotations

import math

import gpytorch
import torch
from gpytorch.constraints import Interval, Positive

KERNEL_NAMES = ("rbf", "matern52", "mlp")

# |argument of asin| is < 1 analytically; the clamp only guards rounding.
_ASIN_LIMIT = 1.0 - 1e-12


def _scaled_sqdist(x1: torch.Tensor, x2: torch.Tensor, lengthscales: torch.Tensor) -> torch.Tensor:
    z1 = x1 / lengthscales
    z2 = x2 / lengthscales
    # ‖a‖² + ‖b‖² − 2a·b in one GEMM; a contiguous right operand is several times faster.
    sq = torch.addmm((z2 * z2).sum(-1), z1, z2.T.contiguous(), alpha=-2.0)
    return sq.add_((z1 * z1).sum(-1, keepdim=True)).clamp_min_(0.0)


def rbf(
    x1: torch.Tensor, x2: torch.Tensor, lengthscales: torch.Tensor, diag: bool = False
) -> torch.Tensor:
    """Squared exponential ARD: ``exp(-r²/2)`` with ``r`` the lengthscale-scaled distance."""
    if diag:
        return torch.ones(x1.shape[0], dtype=x1.dtype)
    return torch.exp(-0.5 * _scaled_sqdist(x1, x2, lengthscales))


def matern52(
    x1: torch.Tensor, x2: torch.Tensor, lengthscales: torch.Tensor, diag: bool = False
) -> torch.Tensor:
    """Matérn-5/2 ARD: ``(1 + √5 r + 5r²/3) exp(-√5 r)``."""
    if diag:
        return torch.ones(x1.shape[0], dtype=x1.dtype)
    # The clamp keeps the gradient of sqrt finite on the diagonal (r = 0).
    s5r = _scaled_sqdist(x1, x2, lengthscales).clamp_min_(1e-30).mul_(5.0).sqrt_()
    return (s5r * s5r).div_(3.0).add_(s5r).add_(1.0) * torch.exp(-s5r)


def arcsine(
    x1: torch.Tensor,
    x2: torch.Tensor,
    weight_variances: torch.Tensor,
    bias_variance: torch.Tensor,
    diag: bool = False,
) -> torch.Tensor:
    """MLP (arcsine) kernel with ARD, without its signal variance.

    ``k(x, x') = (2/π) asin(x̃ᵀΣ²x̃' / sqrt((x̃ᵀΣ²x̃ + 1)(x̃'ᵀΣ²x̃' + 1)))`` with ``x̃ = [1, x]``
    and ``Σ² = diag(bias_variance, weight_variances)``; this equals GPy's ``kern.MLP`` with
    ``ARD=True`` (``weight_variance`` = ``weight_variances``, ``bias_variance`` the same).
    """
    q1 = (x1 * x1 * weight_variances).sum(-1) + bias_variance
    if diag:
        return (2.0 / math.pi) * torch.asin(q1 / (q1 + 1.0))
    q2 = (x2 * x2 * weight_variances).sum(-1) + bias_variance
    cross = (x1 * weight_variances) @ x2.T + bias_variance
    denominator = torch.sqrt((q1 + 1.0).unsqueeze(-1) * (q2 + 1.0).unsqueeze(-2))
    ratio = (cross / denominator).clamp(-_ASIN_LIMIT, _ASIN_LIMIT)
    return (2.0 / math.pi) * torch.asin(ratio)


class ArcsineKernel(gpytorch.kernels.Kernel):
    """The ARD MLP (arcsine) kernel of appendix A as a gpytorch ``Kernel``.

    Hyperparameters: ``weight_variance`` (shape ``(1, d)``, the diagonal of Σ² for ``x``) and
    ``bias_variance`` (shape ``(1,)``). Wrap it in ``ScaleKernel`` for the signal variance.
    Batch shapes other than ``()`` are not supported.
    """

    has_lengthscale = False

    def __init__(
        self,
        ard_num_dims: int = 1,
        weight_variance_constraint: Interval | None = None,
        bias_variance_constraint: Interval | None = None,
        **kwargs: object,
    ) -> None:
        super().__init__(ard_num_dims=ard_num_dims, **kwargs)
        self.register_parameter(
            "raw_weight_variance", torch.nn.Parameter(torch.zeros(1, ard_num_dims))
        )
        self.register_parameter("raw_bias_variance", torch.nn.Parameter(torch.zeros(1)))
        self.register_constraint("raw_weight_variance", weight_variance_constraint or Positive())
        self.register_constraint("raw_bias_variance", bias_variance_constraint or Positive())

    @property
    def weight_variance(self) -> torch.Tensor:
        return self.raw_weight_variance_constraint.transform(self.raw_weight_variance)

    @weight_variance.setter
    def weight_variance(self, value: torch.Tensor | float) -> None:
        value = torch.as_tensor(value, dtype=self.raw_weight_variance.dtype).reshape(1, -1)
        self.initialize(
            raw_weight_variance=self.raw_weight_variance_constraint.inverse_transform(value)
        )

    @property
    def bias_variance(self) -> torch.Tensor:
        return self.raw_bias_variance_constraint.transform(self.raw_bias_variance)

    @bias_variance.setter
    def bias_variance(self, value: torch.Tensor | float) -> None:
        value = torch.as_tensor(value, dtype=self.raw_bias_variance.dtype).reshape(1)
        self.initialize(
            raw_bias_variance=self.raw_bias_variance_constraint.inverse_transform(value)
        )

    def forward(
        self, x1: torch.Tensor, x2: torch.Tensor, diag: bool = False, **params: object
    ) -> torch.Tensor:
        if x1.dim() != 2 or x2.dim() != 2:
            raise ValueError("ArcsineKernel supports inputs of shape (n, d) only")
        weights = self.weight_variance.reshape(-1)
        return arcsine(x1, x2, weights, self.bias_variance.reshape(()), diag=diag)


def unit_kernel(
    name: str, x1: torch.Tensor, x2: torch.Tensor, params: torch.Tensor, diag: bool = False
) -> torch.Tensor:
    """Evaluate kernel ``name`` with its hyperparameters packed as ``params``.

    ``params`` (positive, not logs): ``lengthscales (d,)`` for ``rbf``/``matern52``;
    ``[weight_variances (d,), bias_variance]`` for ``mlp``.
    """
    if name == "rbf":
        return rbf(x1, x2, params, diag)
    if name == "matern52":
        return matern52(x1, x2, params, diag)
    if name == "mlp":
        return arcsine(x1, x2, params[:-1], params[-1], diag)
    raise ValueError(f"unknown kernel {name!r}: expected one of {', '.join(KERNEL_NAMES)}")


def to_gpytorch(name: str, params: torch.Tensor, outputscale: float) -> gpytorch.kernels.Kernel:
    """The gpytorch ``ScaleKernel`` equal to ``outputscale * unit_kernel(name, ·, ·, params)``."""
    params = params.detach().to(torch.float64)
    d = params.numel() - (1 if name == "mlp" else 0)
    if name == "rbf":
        base: gpytorch.kernels.Kernel = gpytorch.kernels.RBFKernel(ard_num_dims=d)
        base.lengthscale = params.reshape(1, d)
    elif name == "matern52":
        base = gpytorch.kernels.MaternKernel(nu=2.5, ard_num_dims=d)
        base.lengthscale = params.reshape(1, d)
    elif name == "mlp":
        base = ArcsineKernel(ard_num_dims=d)
        base.weight_variance = params[:-1]
        base.bias_variance = params[-1]
    else:
        raise ValueError(f"unknown kernel {name!r}: expected one of {', '.join(KERNEL_NAMES)}")
    kernel = gpytorch.kernels.ScaleKernel(base).to(torch.float64)
    kernel.outputscale = torch.tensor(float(outputscale), dtype=torch.float64)
    return kernel
