"""Covariance functions on normalised inputs (appendix A of the paper).

Each kernel is a pure torch function of the inputs and its *unit* hyperparameters (the signal
variance is applied by the GP), so that fitting can differentiate it cheaply;
:mod:`ltamp_cli.learning.gpytorch_kernels` (optional extra ``ltamp[gpytorch]``) wraps them as
gpytorch kernels.

Shapes: ``x1 (n, d)``, ``x2 (m, d)`` -> ``(n, m)``; with ``diag=True`` (``x1 is x2``) ``(n,)``.
"""

from __future__ import annotations

import math

import torch

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


class CrossCovariance:
    """Fast, no-autograd cross-covariances against fixed training inputs (prediction path).

    The training side is reduced once to a feature matrix ``F (n, f)`` so that each kernel's
    cross-covariance is **one** GEMM with the query features followed by a few in-place
    element-wise passes; the result is returned transposed, ``(n, m)``, the layout the
    triangular solve of the predictive variance wants (no copy). Values equal
    :func:`unit_kernel` up to rounding (float64 throughout: the variance subtracts two nearly
    equal numbers near the data, float32 here would swamp small noise variances).

    * ``rbf``: ``F = [z, 1, -|z|²/2]`` and ``G = [z, -|z|²/2, 1]`` with ``z = x/ℓ``, so
      ``F Gᵀ = -r²/2`` and ``k = exp(F Gᵀ)``.
    * ``matern52``: the same with factors giving ``5r²`` directly, then ``√`` and the polynomial.
    * ``mlp``: ``F = [x·√w, √b] / √(|·|² + 1)`` row-wise, so ``F Gᵀ`` is the arcsine argument.
    """

    def __init__(self, name: str, x_train: torch.Tensor, params: torch.Tensor) -> None:
        if name not in KERNEL_NAMES:
            raise ValueError(f"unknown kernel {name!r}: expected one of {', '.join(KERNEL_NAMES)}")
        self.name = name
        with torch.no_grad():
            params = params.detach()
            if name == "mlp":
                self._root_w = params[:-1].sqrt()
                self._root_b = params[-1].sqrt()
                self._train = self._mlp_features(x_train)
            else:
                self._inv_ls = 1.0 / params
                z = x_train * self._inv_ls
                half_sq = 0.5 * (z * z).sum(-1, keepdim=True)
                ones = torch.ones_like(half_sq)
                if name == "rbf":
                    self._train = torch.cat([z, ones, -half_sq], dim=1)
                else:  # 5r² = 5|z|² + 5|z'|² − 10 z·z'
                    self._train = torch.cat([-10.0 * z, 10.0 * half_sq, ones], dim=1)

    def _mlp_features(self, x: torch.Tensor) -> torch.Tensor:
        bias = self._root_b.expand(x.shape[0], 1)
        features = torch.cat([x * self._root_w, bias], dim=1)
        return features.div_((features * features).sum(-1, keepdim=True).add_(1.0).sqrt_())

    def _query(self, x: torch.Tensor) -> torch.Tensor:
        if self.name == "mlp":
            return self._mlp_features(x)
        z = x * self._inv_ls
        half_sq = 0.5 * (z * z).sum(-1, keepdim=True)
        ones = torch.ones_like(half_sq)
        if self.name == "rbf":
            return torch.cat([z, -half_sq, ones], dim=1)
        return torch.cat([z, ones, 10.0 * half_sq], dim=1)

    def transposed(self, x: torch.Tensor, out: torch.Tensor | None = None,
                   work: torch.Tensor | None = None) -> torch.Tensor:
        """``k(x_train, x)`` of shape ``(n, m)`` for queries ``x (m, d)`` (no autograd).

        ``out`` and ``work`` (contiguous ``(n, m)``, optional) are reused instead of allocating:
        fresh multi-megabyte tensors cost page faults comparable to the arithmetic.
        """
        with torch.no_grad():
            product = torch.mm(self._train, self._query(x).T, out=out)  # type: ignore[arg-type]
            if self.name == "rbf":
                return product.clamp_max_(0.0).exp_()
            if self.name == "mlp":
                return product.clamp_(-_ASIN_LIMIT, _ASIN_LIMIT).asin_().mul_(2.0 / math.pi)
            # With n = −s (s = √5·r): t = n − n²/3 = −(s + s²/3), k = e^{n} − t·e^{n}
            # = (1 + s + s²/3)·e^{−s}; in-place passes, e^{n} written straight into ``work``.
            negative = product.clamp_min_(0.0).sqrt_().neg_()
            decay = torch.exp(negative, out=work)  # type: ignore[arg-type]
            return decay.addcmul_(negative.addcmul_(negative, negative, value=-1.0 / 3.0),
                                  decay, value=-1.0)
