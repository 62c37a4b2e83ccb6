"""Exact GP regression on normalised inputs, fitted by bounded maximum marginal likelihood.

Inputs ``x`` are ``(n, d)`` in ``[-1, 1]`` (see :mod:`.normalize`); scores ``y`` are ``(n,)`` in
the skill's own units. Scores are divided by their root mean square before fitting (never
centred, so the sign of the prediction — the level set — is untouched) and predictions are
returned in score units. The prior mean is a fitted constant (``mean="constant"``) or zero.

Hyperparameters are optimised in log space with L-BFGS-B inside box bounds from a warm start,
a default start and random restarts; a Cholesky failure adds growing jitter to the diagonal.
Everything runs in float64 on one thread; predictions are batched in chunks without autograd.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
from scipy.optimize import minimize

from ltamp_cli.learning.kernels import KERNEL_NAMES, CrossCovariance, to_gpytorch, unit_kernel

DTYPE = torch.float64
# Candidates per block: (n, 500) float64 work matrices stay cache-friendly for n ~ 100-400.
PREDICT_CHUNK = 500


class CholeskyError(RuntimeError):
    """The covariance stayed non positive-definite after the largest jitter."""


@dataclass(frozen=True)
class HyperBounds:
    """Box bounds (positive values, not logs) for the hyperparameters in normalised units.

    Inputs span ``[-1, 1]``, so lengthscales above ~20 mean "irrelevant dimension". Variances
    are relative to the RMS-scaled scores.
    """

    lengthscale: tuple[float, float] = (0.05, 20.0)
    weight_variance: tuple[float, float] = (1e-2, 1e3)
    bias_variance: tuple[float, float] = (1e-2, 1e3)
    outputscale: tuple[float, float] = (0.05, 20.0)
    noise: tuple[float, float] = (1e-6, 0.5)
    mean: tuple[float, float] = (-3.0, 3.0)


def n_kernel_params(kernel: str, dim: int) -> int:
    if kernel not in KERNEL_NAMES:
        raise ValueError(f"unknown kernel {kernel!r}: expected one of {', '.join(KERNEL_NAMES)}")
    return dim + 1 if kernel == "mlp" else dim


def robust_cholesky(matrix: torch.Tensor, max_tries: int = 6) -> torch.Tensor:
    """Lower Cholesky factor, adding jitter 1e-9·mean(diag)·10^k (k < ``max_tries``) on failure."""
    factor, info = torch.linalg.cholesky_ex(matrix)
    if int(info) == 0:
        return factor
    scale = float(matrix.diagonal().mean().abs()) or 1.0
    eye = torch.eye(matrix.shape[-1], dtype=matrix.dtype)
    for attempt in range(max_tries):
        jitter = scale * 1e-9 * 10.0**attempt
        factor, info = torch.linalg.cholesky_ex(matrix + jitter * eye)
        if int(info) == 0:
            return factor
    raise CholeskyError(f"covariance not positive definite even with jitter {jitter:.1e}")


def _log_bounds(kernel: str, dim: int, bounds: HyperBounds, mean: str) -> list[tuple[float, float]]:
    def logs(pair: tuple[float, float]) -> tuple[float, float]:
        return (math.log(pair[0]), math.log(pair[1]))

    if kernel == "mlp":
        box = [logs(bounds.weight_variance)] * dim + [logs(bounds.bias_variance)]
    else:
        box = [logs(bounds.lengthscale)] * dim
    box += [logs(bounds.outputscale), logs(bounds.noise)]
    box.append(bounds.mean if mean == "constant" else (0.0, 0.0))
    return box


def _unpack(theta: torch.Tensor, k: int) -> tuple[torch.Tensor, ...]:
    """``theta = [log kernel params (k), log outputscale, log noise, mean]``."""
    return theta[:k].exp(), theta[k].exp(), theta[k + 1].exp(), theta[k + 2]


def _neg_log_likelihood_and_gradient(
    theta: np.ndarray, kernel: str, x: torch.Tensor, y: torch.Tensor
) -> tuple[float, np.ndarray]:
    """Negative log marginal likelihood per data point and its gradient in ``theta``.

    The gradient uses ``∂/∂K = ½ (K⁻¹ − ααᵀ)`` and backpropagates only through the kernel:
    autograd through the Cholesky factorisation costs several times more.
    """
    k = theta.size - 3
    theta_t = torch.tensor(theta, dtype=DTYPE, requires_grad=True)
    params, outputscale, noise, mean = _unpack(theta_t, k)
    n = x.shape[0]
    covariance = outputscale * unit_kernel(kernel, x, x, params)
    covariance = covariance + noise * torch.eye(n, dtype=x.dtype)
    with torch.no_grad():
        factor = robust_cholesky(covariance)
        residual = y - mean
        alpha = torch.cholesky_solve(residual.unsqueeze(-1), factor).squeeze(-1)
        value = (0.5 * residual @ alpha + factor.diagonal().log().sum()) / n
        inverse = torch.cholesky_inverse(factor)
        upstream = 0.5 * (inverse - torch.outer(alpha, alpha)) / n
    covariance.backward(upstream)
    assert theta_t.grad is not None
    gradient = theta_t.grad.numpy().copy()
    gradient[k + 2] = -float(alpha.sum()) / n
    return float(value) + 0.5 * math.log(2.0 * math.pi), gradient


class GaussianProcess:
    """A GP posterior with fixed hyperparameters on fixed data (normalised inputs).

    Build one with :func:`fit_gp` (optimises hyperparameters) or :meth:`with_data` (reuses
    them). ``theta`` is ``[log kernel params, log outputscale, log noise, mean]`` in scaled
    score units (see module doc).
    """

    def __init__(
        self,
        kernel: str,
        x: np.ndarray,
        y: np.ndarray,
        theta: np.ndarray,
        y_scale: float,
        mean_mode: str = "constant",
        nll: float = float("nan"),
    ) -> None:
        self.kernel = kernel
        self.mean_mode = mean_mode
        self.x_np = np.asarray(x, dtype=float).reshape(len(y), -1)
        self.y_np = np.asarray(y, dtype=float).reshape(-1)
        self.theta = np.asarray(theta, dtype=float).copy()
        self.y_scale = float(y_scale)
        self.nll = float(nll)
        self.dim = self.x_np.shape[1]
        self._k = n_kernel_params(kernel, self.dim)
        with torch.no_grad():
            self._x = torch.as_tensor(self.x_np, dtype=DTYPE)
            theta_t = torch.as_tensor(self.theta, dtype=DTYPE)
            self._params, outputscale, noise, mean = _unpack(theta_t, self._k)
            self._outputscale = float(outputscale)
            self._noise = float(noise)
            self._mean = float(mean)
            covariance = self._outputscale * unit_kernel(kernel, self._x, self._x, self._params)
            covariance += self._noise * torch.eye(len(self.y_np), dtype=DTYPE)
            self._factor = robust_cholesky(covariance)
            residual = torch.as_tensor(self.y_np / self.y_scale - self._mean, dtype=DTYPE)
            self._alpha = torch.cholesky_solve(residual.unsqueeze(-1), self._factor).squeeze(-1)
            # Training-side kernel features for the no-autograd prediction path.
            self._cross = CrossCovariance(kernel, self._x, self._params)

    # ---- hyperparameters in readable form -------------------------------------------------
    @property
    def n(self) -> int:
        return len(self.y_np)

    @property
    def kernel_params(self) -> np.ndarray:
        """Positive kernel hyperparameters: lengthscales ``(d,)`` or ``[weights (d,), bias]``."""
        return np.exp(self.theta[: self._k])

    @property
    def lengthscales(self) -> np.ndarray:
        """ARD lengthscales ``(d,)`` in normalised units (``mlp``: ``1/sqrt(weight variance)``)."""
        params = self.kernel_params
        if self.kernel == "mlp":
            return 1.0 / np.sqrt(params[: self.dim])
        return params

    @property
    def outputscale(self) -> float:
        """Signal variance in score units squared."""
        return self._outputscale * self.y_scale**2

    @property
    def noise(self) -> float:
        """Observation noise variance in score units squared."""
        return self._noise * self.y_scale**2

    @property
    def mean_constant(self) -> float:
        return self._mean * self.y_scale

    def hyperparameters(self) -> dict[str, object]:
        """JSON-able summary in score units."""
        summary: dict[str, object] = {
            "kernel": self.kernel,
            "lengthscales": self.lengthscales.tolist(),
            "outputscale": self.outputscale,
            "noise": self.noise,
            "mean": self.mean_constant,
            "mean_mode": self.mean_mode,
            "neg_log_likelihood_per_point": self.nll,
        }
        if self.kernel == "mlp":
            summary["weight_variances"] = self.kernel_params[:-1].tolist()
            summary["bias_variance"] = float(self.kernel_params[-1])
        return summary

    def gpytorch_kernel(self):
        """The equivalent gpytorch ``ScaleKernel`` (outputscale in scaled-score units)."""
        return to_gpytorch(self.kernel, torch.as_tensor(self.kernel_params), self._outputscale)

    # ---- prediction --------------------------------------------------------------------------
    def posterior_torch(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Latent ``(mean (m,), variance (m,))`` (scaled units) at ``x (m, d)``.

        Differentiable when autograd is on; under ``torch.no_grad()`` it takes the fast path
        of :meth:`posterior_blocks` (same values up to rounding).
        """
        if not torch.is_grad_enabled():
            means, variances = self.posterior_blocks(x)
            return means, variances
        # The outputscale s is folded into scalars: k = s·u, so μ = m + s·uᵀα and
        # σ² = s·u(x, x) − s²‖L⁻¹u‖² — no full-size rescaled copy of the cross-covariance.
        scale = self._outputscale
        cross = unit_kernel(self.kernel, x, self._x, self._params)
        mean = self._mean + scale * (cross @ self._alpha)
        solved = torch.linalg.solve_triangular(self._factor, cross.T, upper=False)
        prior = unit_kernel(self.kernel, x, x, self._params, diag=True)
        variance = scale * prior - (scale * scale) * solved.square().sum(0)
        return mean, variance.clamp_min(1e-12 * scale)

    def posterior_blocks(
        self, x: torch.Tensor, chunk: int = PREDICT_CHUNK
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Latent ``(mean (m,), variance (m,))`` (scaled units) at ``x (m, d)``, no autograd.

        Per block of ``chunk`` candidates: the transposed cross-covariance ``U (n, b)`` in one
        GEMM (:class:`CrossCovariance`), ``μ = m + s·αᵀU`` and ``σ² = s·u** − s²‖L⁻¹U‖²``
        from the cached Cholesky factor ``L`` and ``α = K⁻¹(y − m)``; the three ``(n, b)``
        work matrices are allocated once per call.
        """
        with torch.no_grad():
            x = x.to(DTYPE).reshape(-1, self.dim)
            m, n = x.shape[0], self.n
            scale = self._outputscale
            means = torch.empty(m, dtype=DTYPE)
            variances = torch.empty(m, dtype=DTYPE)
            size = n * min(chunk, max(m, 1))
            cross_buffer, solved_buffer, work_buffer = (
                torch.empty(size, dtype=DTYPE) for _ in range(3)
            )
            for start in range(0, m, chunk):
                block = x[start : start + chunk]
                b = block.shape[0]
                cross = self._cross.transposed(
                    block, cross_buffer[: n * b].view(n, b), work_buffer[: n * b].view(n, b)
                )
                torch.mv(cross.T, self._alpha, out=means[start : start + b])
                solved = solved_buffer[: n * b].view(n, b)
                torch.linalg.solve_triangular(self._factor, cross, upper=False, out=solved)
                quadratic = solved.mul_(solved).sum(0)
                prior = unit_kernel(self.kernel, block, block, self._params, diag=True)
                variances[start : start + b] = prior.mul_(scale).sub_(quadratic, alpha=scale**2)
            means.mul_(scale).add_(self._mean)
            return means, variances.clamp_min_(1e-12 * scale)

    def predict(self, x: np.ndarray, chunk: int = PREDICT_CHUNK) -> tuple[np.ndarray, np.ndarray]:
        """Latent posterior ``(mean (m,), std (m,))`` in score units for ``x (m, d)`` normalised."""
        x_t = torch.as_tensor(np.asarray(x, dtype=float).reshape(-1, self.dim), dtype=DTYPE)
        mean, variance = self.posterior_blocks(x_t, chunk)
        return mean.numpy() * self.y_scale, variance.sqrt_().numpy() * self.y_scale

    def with_data(self, x: np.ndarray, y: np.ndarray) -> GaussianProcess:
        """Same hyperparameters (in score units) conditioned on new data; no optimisation."""
        scale = _score_scale(y)
        theta = self.theta.copy()
        # Keep outputscale, noise and mean fixed in *score* units under the new scaling.
        ratio = self.y_scale / scale
        theta[self._k] += 2.0 * math.log(ratio)
        theta[self._k + 1] += 2.0 * math.log(ratio)
        theta[self._k + 2] *= ratio
        return GaussianProcess(self.kernel, x, y, theta, scale, self.mean_mode)

    # ---- persistence -------------------------------------------------------------------------
    def state(self) -> dict[str, np.ndarray]:
        return {
            "x": self.x_np,
            "y": self.y_np,
            "theta": self.theta,
            "y_scale": np.array(self.y_scale),
            "nll": np.array(self.nll),
        }

    @staticmethod
    def from_state(kernel: str, mean_mode: str, state: dict[str, np.ndarray]) -> GaussianProcess:
        return GaussianProcess(
            kernel,
            state["x"],
            state["y"],
            state["theta"],
            float(state["y_scale"]),
            mean_mode,
            float(state["nll"]),
        )


def _score_scale(y: np.ndarray) -> float:
    rms = float(np.sqrt(np.mean(np.square(y)))) if len(y) else 0.0
    return rms if rms > 1e-12 else 1.0


def fit_gp(
    x: np.ndarray,
    y: np.ndarray,
    kernel: str = "matern52",
    *,
    mean: str = "constant",
    restarts: int = 2,
    rng: np.random.Generator | None = None,
    warm_start: GaussianProcess | None = None,
    bounds: HyperBounds | None = None,
    max_iter: int = 200,
) -> GaussianProcess:
    """Fit hyperparameters by maximum marginal likelihood and return the posterior.

    Starts: ``warm_start``'s hyperparameters (if given), a default point (unless only the warm
    start is asked for: ``restarts=0``), and ``restarts`` random points drawn log-uniformly from a
    central part of the bounds. Each start runs
    L-BFGS-B inside the bounds; the lowest negative log likelihood wins.
    """
    if mean not in ("constant", "zero"):
        raise ValueError(f"mean must be 'constant' or 'zero', not {mean!r}")
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float).reshape(-1)
    if x.ndim != 2 or len(x) != len(y) or len(y) == 0:
        raise ValueError(f"need x (n, d) and y (n,) with n > 0, got {x.shape} and {y.shape}")
    if not np.all(np.isfinite(y)):
        raise ValueError("scores must be finite")
    rng = rng if rng is not None else np.random.default_rng(0)
    bounds = bounds or HyperBounds()
    dim = x.shape[1]
    k = n_kernel_params(kernel, dim)
    box = _log_bounds(kernel, dim, bounds, mean)
    lows = np.array([b[0] for b in box])
    highs = np.array([b[1] for b in box])
    scale = _score_scale(y)
    x_t = torch.as_tensor(x, dtype=DTYPE)
    y_t = torch.as_tensor(y / scale, dtype=DTYPE)

    def objective(theta: np.ndarray) -> tuple[float, np.ndarray]:
        try:
            return _neg_log_likelihood_and_gradient(theta, kernel, x_t, y_t)
        except CholeskyError:
            return 1e10, np.zeros_like(theta)

    starts: list[np.ndarray] = []
    if warm_start is not None and warm_start.kernel == kernel and warm_start.dim == dim:
        starts.append(warm_start.with_data(x, y).theta)
    default = np.concatenate(
        [
            np.zeros(k),
            [0.0, math.log(1e-3), float(np.mean(y) / scale) if mean == "constant" else 0.0],
        ]
    )
    if not starts or restarts > 0:
        starts.append(default)
    central_lows = np.concatenate([np.full(k, math.log(0.1)), [math.log(0.2), math.log(1e-5)]])
    central_highs = np.concatenate([np.full(k, math.log(5.0)), [math.log(5.0), math.log(1e-1)]])
    for _ in range(restarts):
        start = rng.uniform(central_lows, central_highs)
        starts.append(np.concatenate([start, [default[-1]]]))

    best_theta, best_value = None, math.inf
    for start in starts:
        start = np.clip(start, lows, highs)
        result = minimize(
            objective,
            start,
            jac=True,
            method="L-BFGS-B",
            bounds=list(zip(lows, highs, strict=True)),
            options={"maxiter": max_iter},
        )
        if np.isfinite(result.fun) and result.fun < best_value:
            best_theta, best_value = np.clip(result.x, lows, highs), float(result.fun)
    if best_theta is None:
        raise CholeskyError("no hyperparameter start gave a positive-definite covariance")
    return GaussianProcess(kernel, x, y, best_theta, scale, mean, best_value)
