"""Exact GP regression on normalised inputs, fitted by bounded maximum marginal likelihood.

Inputs ``x`` are ``(n, d)`` in ``[-1, 1]`` (see :mod:`.normalize`); scores ``y`` are ``(n,)`` in
the skill's own units. Scores are divided by their root mean square before fitting (never
centred, so the sign of the prediction — the level set — is untouched) and predictions are
returned in score units. The prior mean is a fitted constant (``mean="constant"``) or zero.

Hyperparameters are optimised in log space with L-BFGS-B inside box bounds from a warm start,
a default start and random restarts; a Cholesky failure adds growing jitter to the diagonal.
By default the objective is the marginal likelihood times a weak log-normal prior on the
stationary kernels' lengthscales (MAP, :class:`LengthscalePrior`, issue #21): with few
successes among many equal failures, the pure marginal likelihood's optimum may call every
control irrelevant (lengthscales at the upper bound) and explain the successes by one context
lengthscale at the lower bound, and the straddle then has nothing to say about controls.
Everything runs in float64 on one thread; predictions are batched in chunks without autograd.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
from scipy.optimize import minimize

from ltamp_cli.learning.kernels import (
    _ASIN_LIMIT,
    KERNEL_NAMES,
    CrossCovariance,
    unit_kernel,
)

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


@dataclass(frozen=True)
class LengthscalePrior:
    """Independent log-normal prior on each ARD lengthscale ``ℓ_d`` (normalised units):
    ``log ℓ_d ~ N(log median, log_sd²)``.

    Hand-written (MAP on top of the marginal likelihood) because scikit-learn's GP takes no
    hyperparameter priors and this module's fit is its own L-BFGS-B over closed-form gradients.
    The default median 1 is half the width of the normalised box ``[-1, 1]``: a priori the
    score changes over a fraction of each parameter's range. ``log_sd = 1`` makes ℓ = 20 (the
    upper bound, "irrelevant") cost 4.5 nats and ℓ = 0.05 (the lower bound) 4.5 nats per
    dimension against the *total* log marginal likelihood of all n points, so data that clearly
    need a short or irrelevant dimension still get it. The MLP kernel is left without a prior
    (penalty 0): its weight variances set the slope of non-stationary features, not a
    correlation length, and a prior on ``1/sqrt(weight)`` broke a 40-trial ``moving2d`` MLP fit
    (``tests/learning/test_cli_learning.py``: F1 0.0 at the last checkpoint).
    """

    median: float = 1.0
    log_sd: float = 1.0

    def __post_init__(self) -> None:
        if not (self.median > 0 and self.log_sd > 0):
            raise ValueError(f"need median > 0 and log_sd > 0, got {self.median}, {self.log_sd}")

    def penalty_and_gradient(self, kernel: str, log_params: np.ndarray, dim: int
                             ) -> tuple[float, np.ndarray]:
        """``−log prior`` (up to a constant) and its gradient in the log kernel parameters
        ``(k,)``: log lengthscales ``(d,)`` (MLP: zero, see the class doc)."""
        gradient = np.zeros(log_params.size)
        if kernel == "mlp":
            return 0.0, gradient
        z = (log_params[:dim] - math.log(self.median)) / self.log_sd
        gradient[:dim] = z / self.log_sd
        return float(0.5 * np.sum(z * z)), gradient


#: The prior :func:`fit_gp` uses unless told otherwise.
DEFAULT_PRIOR = LengthscalePrior()


@dataclass(frozen=True)
class OutputscalePrior:
    """Log-normal prior on the outputscale ``s`` (the kernel's variance, in units of the
    RMS-scaled scores): ``log s ~ N(log median, log_sd²)``.

    Scores are divided by their RMS, so a priori the score varies by about its own size:
    median 1. ``log_sd = 2`` costs 1.1 nats at the bounds (0.05 and 20), against the total
    log likelihood of all points: data that show the variation (many distinct inputs) set
    ``s`` (a smooth noise-free 60-point fit: ``s`` 8.7 before, 8.8 with it, 4.6 with
    ``log_sd = 1``, which moved it along the likelihood's ``s``–lengthscale ridge). It decides
    ``s`` where the data cannot: when every input is the same point, the restricted
    likelihood (see :func:`fit_gp`) is flat in ``s``.
    """

    median: float = 1.0
    log_sd: float = 2.0

    def __post_init__(self) -> None:
        if not (self.median > 0 and self.log_sd > 0):
            raise ValueError(f"need median > 0 and log_sd > 0, got {self.median}, {self.log_sd}")

    def penalty_and_gradient(self, log_outputscale: float) -> tuple[float, float]:
        """``−log prior`` (up to a constant) and its derivative in ``log s``."""
        z = (log_outputscale - math.log(self.median)) / self.log_sd
        return 0.5 * z * z, z / self.log_sd


#: The outputscale prior :func:`fit_gp` uses unless told otherwise.
DEFAULT_OUTPUTSCALE_PRIOR = OutputscalePrior()

#: Names :func:`fit_gp`'s default objective (restricted likelihood with a constant mean,
#: lengthscale and outputscale priors). Results that depend on how GPs are fitted (the
#: benchmarks' job logs) are keyed on it, so a change of the fit is never mixed with
#: results of the old one: change it whenever the default fit changes.
FIT_OBJECTIVE = "map-reml-1"


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


def _stationary_kernel_and_slope(
    kernel: str, z: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """Unit kernel ``K (n, n)`` and ``∂K/∂r² (n, n)`` for scaled inputs ``z = x/ℓ (n, d)``.

    ``rbf``: ``K = e^{−r²/2}``, slope ``−K/2``. ``matern52`` with ``s = √5 r``:
    ``K = (1 + s + s²/3) e^{−s}`` and ``∂K/∂r² = −(5/6)(1 + s) e^{−s}`` (finite at ``r = 0``).
    """
    sq = (z * z).sum(-1)
    r2 = torch.addmm(sq.unsqueeze(-1) + sq, z, z.T, alpha=-2.0).clamp_min_(0.0)
    if kernel == "rbf":
        value = torch.exp(r2.mul_(-0.5))
        return value, value * -0.5
    s = r2.mul_(5.0).sqrt_()
    decay = torch.exp(-s)
    value = (s * s / 3.0 + s + 1.0) * decay
    return value, (s + 1.0).mul_(decay).mul_(-5.0 / 6.0)


def _arcsine_kernel_and_slope(
    x: torch.Tensor, params: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor, tuple[torch.Tensor, torch.Tensor, torch.Tensor]]:
    """MLP kernel ``K = (2/π) asin(a)`` and ``∂K/∂a`` at the training inputs ``x (n, d)``.

    ``a_ij = c_ij / D_ij`` with ``c = x̃ Σ x̃ᵀ``, ``q_i = c_ii``, ``D_ij = √((q_i+1)(q_j+1))``,
    ``x̃ = [x, 1]`` and ``Σ = diag(params)`` (weights, then bias: :func:`unit_kernel`'s order).
    Also returns ``(x̃, a, 1/D)`` for :func:`_arcsine_gradient`.
    """
    augmented = torch.cat([x, torch.ones(x.shape[0], 1, dtype=x.dtype)], dim=1)
    cross = (augmented * params) @ augmented.T
    inv_root = (cross.diagonal() + 1.0).rsqrt()
    inv_denominator = inv_root.unsqueeze(-1) * inv_root
    ratio = cross.mul_(inv_denominator)
    inside = ratio.abs() < _ASIN_LIMIT  # the forward clamps: no gradient where it bites
    ratio.clamp_(-_ASIN_LIMIT, _ASIN_LIMIT)
    value = torch.asin(ratio).mul_(2.0 / math.pi)
    slope = (1.0 - ratio * ratio).rsqrt_().mul_(2.0 / math.pi).mul_(inside)
    return value, slope, (augmented, ratio, inv_denominator)


def _arcsine_gradient(weighted: torch.Tensor, unit: torch.Tensor,
                      features: tuple[torch.Tensor, torch.Tensor, torch.Tensor],
                      params: torch.Tensor) -> torch.Tensor:
    """``∂/∂log σ_m`` of ``Σ_ij W_ij a_ij`` for the MLP kernel (``W`` symmetric).

    ``∂a_ij/∂σ_m = x̃_im x̃_jm / D_ij − (a_ij/2)(x̃_im²/(q_i+1) + x̃_jm²/(q_j+1))``, so the sum is
    ``σ_m [Σ_i x̃_im ((W/D) x̃)_im − Σ_i x̃_im² r_i/(q_i+1)]`` with ``r = (W∘a)`` row sums.
    """
    augmented, ratio, inv_denominator = features
    q_plus_one = (augmented * augmented * params).sum(-1) + 1.0
    row = (weighted * ratio).sum(1) / q_plus_one
    pulled = (weighted * inv_denominator) @ augmented
    return params * ((augmented * pulled).sum(0) - (augmented * augmented).T @ row)


def _neg_log_likelihood_and_gradient(
    theta: np.ndarray, kernel: str, x: torch.Tensor, y: torch.Tensor, restricted: bool = False
) -> tuple[float, np.ndarray]:
    """Negative log marginal likelihood per data point and its gradient in ``theta``.

    ``restricted``: add the REML term ``½ log(1ᵀK⁻¹1)`` (per point), the price of estimating
    the constant mean from the same data (its gradient joins the upstream as
    ``−½ vvᵀ/(1ᵀv)``, ``v = K⁻¹1``; it does not depend on the mean). At the optimum over the
    mean this is the restricted likelihood, whose outputscale is not biased towards zero by
    the degree of freedom the mean takes (:func:`fit_gp`).

    The gradient uses ``∂/∂K = ½ (K⁻¹ − ααᵀ)`` (the upstream ``U``); autograd through the
    Cholesky factorisation would cost several times more. For the stationary kernels the
    lengthscale gradient is closed-form: with ``W = U ∘ s·∂K/∂r²`` (symmetric),
    ``∂/∂log ℓ_d = Σ_ij W_ij ∂r²_ij/∂log ℓ_d = −4 (Σ_i z_id² w_i − Σ_i z_id (Wz)_id)``
    (``w`` the row sums of ``W``), two GEMMs instead of backpropagating through the kernel.
    The MLP kernel backpropagates through its torch expression.
    """
    k = theta.size - 3
    n = x.shape[0]
    with torch.no_grad():
        theta_t = torch.as_tensor(theta, dtype=DTYPE)
        params, outputscale, noise, mean = _unpack(theta_t, k)
        if kernel == "mlp":
            unit, slope, features = _arcsine_kernel_and_slope(x, params)
        else:
            features = x / params
            unit, slope = _stationary_kernel_and_slope(kernel, features)
        covariance = outputscale * unit
        covariance.diagonal().add_(noise)
        factor = robust_cholesky(covariance)
        residual = y - mean
        alpha = torch.cholesky_solve(residual.unsqueeze(-1), factor).squeeze(-1)
        value = (0.5 * residual @ alpha + factor.diagonal().log().sum()) / n
        inverse = torch.cholesky_inverse(factor)
        upstream = 0.5 * (inverse - torch.outer(alpha, alpha)) / n
        if restricted:
            ones_solved = inverse.sum(1)  # v = K⁻¹1 (K⁻¹ is symmetric)
            precision = ones_solved.sum()  # 1ᵀK⁻¹1 > 0
            value = value + 0.5 * precision.log() / n
            upstream -= (0.5 / n) * torch.outer(ones_solved, ones_solved) / precision
        gradient = np.empty(theta.size)
        weighted = upstream * slope.mul_(outputscale)  # W = U ∘ s·∂K/∂(kernel input)
        if kernel == "mlp":
            gradient[:k] = _arcsine_gradient(weighted, unit, features, params).numpy()
        else:
            row_sums = weighted.sum(1)
            pulled = weighted @ features
            sq = features * features
            gradient[:k] = (-4.0 * (sq.T @ row_sums - (features * pulled).sum(0))).numpy()
        gradient[k] = float(outputscale * (upstream * unit).sum())
        gradient[k + 1] = float(noise * upstream.diagonal().sum())
        gradient[k + 2] = -float(alpha.sum()) / n
    return float(value) + 0.5 * math.log(2.0 * math.pi), gradient


def _neg_log_likelihood_autograd(
    theta: np.ndarray, kernel: str, x: torch.Tensor, y: torch.Tensor, restricted: bool = False
) -> tuple[float, np.ndarray]:
    """Reference for tests: the same value with the gradient by autograd through everything."""
    k = theta.size - 3
    theta_t = torch.tensor(theta, dtype=DTYPE, requires_grad=True)
    params, outputscale, noise, mean = _unpack(theta_t, k)
    n = x.shape[0]
    covariance = outputscale * unit_kernel(kernel, x, x, params)
    covariance = covariance + noise * torch.eye(n, dtype=x.dtype)
    factor = torch.linalg.cholesky(covariance)
    residual = y - mean
    alpha = torch.cholesky_solve(residual.unsqueeze(-1), factor).squeeze(-1)
    value = (0.5 * residual @ alpha + factor.diagonal().log().sum()) / n
    if restricted:
        ones = torch.ones(n, dtype=x.dtype)
        precision = ones @ torch.cholesky_solve(ones.unsqueeze(-1), factor).squeeze(-1)
        value = value + 0.5 * precision.log() / n
    value.backward()
    assert theta_t.grad is not None
    return float(value.detach()) + 0.5 * math.log(2.0 * math.pi), theta_t.grad.numpy().copy()


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
        """The equivalent gpytorch ``ScaleKernel`` (outputscale in scaled-score units); needs
        the ``ltamp[gpytorch]`` extra."""
        from ltamp_cli.learning.gpytorch_kernels import to_gpytorch

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
            # prior variance s·u(x, x) for every candidate in one call (per block it is a
            # handful of tiny ops whose overhead adds up)
            variances = unit_kernel(self.kernel, x, x, self._params, diag=True).mul_(scale)
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
                variances[start : start + b].sub_(quadratic, alpha=scale**2)
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
    """The scores' RMS, which the GP works in units of (1 for all-zero scores).

    Only the sign of a score decides success, so the fit must not depend on its unit: scores
    of ±1e-13 (or 1e-200, whose squares underflow) are divided by their RMS as ±1 are. They
    were once left in score units under a 1e-12 cut-off, and the noise floor swallowed them
    (a model of ±1e-13 scores had μ/σ ≈ 1e-10 at the centre of its success region).
    """
    rms = float(np.sqrt(np.mean(np.square(y)))) if len(y) else 0.0
    if rms > 1e-12:
        return rms  # the common case, computed as it always was (fits stay bit for bit)
    peak = float(np.max(np.abs(y))) if len(y) else 0.0
    if not 0.0 < peak < math.inf:
        return 1.0
    return peak * float(np.sqrt(np.mean(np.square(np.asarray(y) / peak))))


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
    prior: LengthscalePrior | None = DEFAULT_PRIOR,
    outputscale_prior: OutputscalePrior | None = DEFAULT_OUTPUTSCALE_PRIOR,
) -> GaussianProcess:
    """Fit hyperparameters by maximum a posteriori (marginal likelihood × ``prior`` on the
    lengthscales × ``outputscale_prior``; both ``None``: maximum marginal likelihood) and
    return the posterior.

    With ``mean="constant"`` the likelihood is the restricted one (REML: the constant mean
    integrated out under a flat prior, :func:`_neg_log_likelihood_and_gradient`). The plain
    likelihood with a fitted constant estimates the outputscale from residuals the mean has
    already shrunk: with few distinct inputs it drives ``s`` to its lower bound — 30 trials
    at one input, all scoring 0.5, gave a GP sure of success (μ/σ ≈ 27) far from that input.

    Starts: ``warm_start``'s hyperparameters (if given), a default point (unless only the warm
    start is asked for: ``restarts=0``), and ``restarts`` random points drawn log-uniformly from a
    central part of the bounds. Each start runs
    L-BFGS-B inside the bounds; the lowest objective wins. The returned ``nll`` is the
    negative log marginal likelihood per point at the chosen hyperparameters (priors and the
    REML term excluded).
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

    n = len(y)

    def objective(theta: np.ndarray) -> tuple[float, np.ndarray]:
        try:
            value, gradient = _neg_log_likelihood_and_gradient(
                theta, kernel, x_t, y_t, restricted=mean == "constant")
        except CholeskyError:
            return 1e10, np.zeros_like(theta)
        if prior is not None:  # the likelihood is per point: so are the priors
            penalty, slope = prior.penalty_and_gradient(kernel, theta[:k], dim)
            value += penalty / n
            gradient[:k] += slope / n
        if outputscale_prior is not None:
            penalty, slope_s = outputscale_prior.penalty_and_gradient(float(theta[k]))
            value += penalty / n
            gradient[k] += slope_s / n
        return value, gradient

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
    if prior is not None or outputscale_prior is not None or mean == "constant":
        best_value = _neg_log_likelihood_and_gradient(best_theta, kernel, x_t, y_t)[0]
    return GaussianProcess(kernel, x, y, best_theta, scale, mean, best_value)
