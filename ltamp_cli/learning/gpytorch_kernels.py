"""The kernels of :mod:`ltamp_cli.learning.kernels` as gpytorch kernels (optional).

For use of ltamp's fitted GPs inside gpytorch/BoTorch models; ltamp itself never needs
gpytorch. Needs the extra: ``pip install 'ltamp[gpytorch]'``.
:class:`ArcsineKernel` wraps the MLP kernel as a gpytorch ``Kernel`` and :func:`to_gpytorch`
builds the equivalent gpytorch kernel of any fitted GP.
"""

from __future__ import annotations

import gpytorch
import torch
from gpytorch.constraints import Interval, Positive

from ltamp_cli.learning.kernels import KERNEL_NAMES, arcsine


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
