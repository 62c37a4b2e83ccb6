"""The GP posterior restricted to one context: ``(μ, σ)`` over controls only, fast.

Samplers evaluate ``μ/σ`` on tens of thousands of controls for one fixed context. The
context part of every squared distance to the training inputs is the same for all those
controls, so it is computed once; the rest is a few NumPy passes over an ``(m, n_train)``
matrix. Means are computed first so that callers can skip the (costlier) variance of
controls that cannot pass a positive threshold.

Coordinates are the learner's normalised ones: controls ``u (m, dθ)`` in ``[-1, 1]``.
Predictions are the latent posterior in score units, identical (to rounding) to
:meth:`ltamp_cli.learning.model.LevelSetModel.predict_normalized`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import cho_solve, solve_triangular

from ltamp_cli.learning.model import LevelSetModel

FAST_KERNELS = ("rbf", "matern52")
# Rows per block: keeps the (rows, n_train) scratch in cache.
CHUNK = 1024
_SQRT5 = math.sqrt(5.0)


def _cholesky_with_jitter(matrix: np.ndarray, max_tries: int = 6) -> np.ndarray:
    """Lower factor; same jitter ladder as the learning package (1e-9·mean diag·10^k)."""
    try:
        return np.linalg.cholesky(matrix)
    except np.linalg.LinAlgError:
        pass
    scale = float(np.abs(np.diag(matrix).mean())) or 1.0
    eye = np.eye(len(matrix))
    for attempt in range(max_tries):
        try:
            return np.linalg.cholesky(matrix + scale * 1e-9 * 10.0**attempt * eye)
        except np.linalg.LinAlgError:
            continue
    raise np.linalg.LinAlgError("training covariance is not positive definite")


class ContextPosterior:
    """``(μ, σ)`` of a :class:`LevelSetModel` at normalised controls for one context.

    ``context_unit (dα,)`` is the context in normalised coordinates. Kernels other than
    ``rbf``/``matern52`` fall back to the model's own (slower) prediction.
    """

    def __init__(self, model: LevelSetModel, context_unit: np.ndarray) -> None:
        self.model = model
        self.d_control = model.spec.control.dim
        self.context_unit = np.asarray(context_unit, dtype=float).reshape(model.spec.context.dim)
        gp = model.gp
        self.fast = gp.kernel in FAST_KERNELS
        if not self.fast:
            return
        lengthscales = gp.lengthscales
        x = gp.x_np
        z_train = x[:, : self.d_control] / lengthscales[: self.d_control]
        context_z = (x[:, self.d_control :] - self.context_unit) / lengthscales[self.d_control :]
        context_sq = (context_z**2).sum(axis=1)
        self._inv_ls = 1.0 / lengthscales[: self.d_control]
        self._z_train_t = np.ascontiguousarray(z_train.T)
        # Per training point: ‖z_i‖² plus the constant context part of the distance.
        self._offset = (z_train**2).sum(axis=1) + context_sq
        self._outputscale = gp.outputscale
        self._mean = gp.mean_constant
        # Training covariance from the full inputs (contexts differ between training points).
        z_all = x / lengthscales
        sq_all = np.maximum(
            (z_all**2).sum(1)[:, None] - 2.0 * z_all @ z_all.T + (z_all**2).sum(1)[None, :], 0.0
        )
        covariance = self._outputscale * self._unit_kernel(sq_all) + gp.noise * np.eye(len(x))
        self._factor = _cholesky_with_jitter(covariance)
        self._alpha = cho_solve((self._factor, True), gp.y_np - self._mean)
        # ‖L⁻¹k‖² as a row-major product: one GEMM instead of a transposed triangular solve.
        self._factor_inv_t = np.ascontiguousarray(
            solve_triangular(self._factor, np.eye(len(x)), lower=True).T
        )

    def _unit_kernel(self, sq: np.ndarray, work: np.ndarray | None = None) -> np.ndarray:
        """Unit kernel of squared scaled distances, in place (``work``: same-shape scratch)."""
        if self.model.gp.kernel == "rbf":
            sq *= -0.5
            return np.exp(sq, out=sq)
        work = np.empty_like(sq) if work is None else work
        np.sqrt(sq, out=sq)
        sq *= _SQRT5
        # (1 + s + s²/3) e^{-s} without fresh temporaries: large temporaries page-fault.
        np.multiply(sq, sq, out=work)
        work *= 1.0 / 3.0
        work += sq
        work += 1.0
        np.negative(sq, out=sq)
        np.exp(sq, out=sq)
        sq *= work
        return sq

    def _cross(self, u: np.ndarray) -> np.ndarray:
        """Cross-covariance ``(m, n_train)`` in score units, built in row chunks."""
        cross = np.empty((len(u), len(self._offset)))
        work = np.empty((min(CHUNK, len(u)), len(self._offset)))
        for start in range(0, len(u), CHUNK):
            z = u[start : start + CHUNK] * self._inv_ls
            block = cross[start : start + CHUNK]
            np.matmul(z, self._z_train_t, out=block)
            block *= -2.0
            block += (z * z).sum(axis=1)[:, None]
            block += self._offset[None, :]
            np.maximum(block, 0.0, out=block)
            self._unit_kernel(block, work[: len(block)])
        cross *= self._outputscale
        return cross

    def full_inputs(self, u: np.ndarray) -> np.ndarray:
        """Normalised GP inputs ``(m, d)`` for controls ``u (m, dθ)``."""
        u = np.asarray(u, dtype=float).reshape(-1, self.d_control)
        context = np.broadcast_to(self.context_unit, (len(u), len(self.context_unit)))
        return np.concatenate([u, context], axis=1)

    def mean_and_cross(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """``(μ (m,), cross-covariance (m, n_train) or None)``; pass the latter to :meth:`std`."""
        if not self.fast:
            mean, _ = self.model.predict_normalized(self.full_inputs(u))
            return mean, None
        cross = self._cross(np.asarray(u, dtype=float).reshape(-1, self.d_control))
        return self._mean + cross @ self._alpha, cross

    def std(self, u: np.ndarray, cross: np.ndarray | None = None) -> np.ndarray:
        """``σ (m,)`` at controls ``u``; reuses ``cross`` rows from :meth:`mean_and_cross`."""
        if not self.fast:
            return self.model.predict_normalized(self.full_inputs(u))[1]
        if cross is None:
            cross = self._cross(np.asarray(u, dtype=float).reshape(-1, self.d_control))
        solved = cross @ self._factor_inv_t
        variance = self._outputscale - np.einsum("ij,ij->i", solved, solved)
        return np.sqrt(np.maximum(variance, 1e-12 * self._outputscale))

    def predict(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(μ (m,), σ (m,))`` at normalised controls ``u (m, dθ)``."""
        mean, cross = self.mean_and_cross(u)
        return mean, self.std(u, cross)
