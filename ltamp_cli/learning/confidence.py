"""Confidence thresholds on ``φ = μ/σ`` (section 4.2 of the paper).

* :func:`beta_star` — Corollary 1: with ``β*_i = sqrt(2 log(π_i / (2δ)))`` and
  ``Σ_i 1/π_i ≤ 1``, if every one of ``T`` samples has ``φ > β*_i`` then all succeed with
  probability ``≥ 1 − δ``.
* :func:`relaxed_beta` — ``β = Φ⁻¹(λ Φ(φ(θ*)))``, the relaxation used when the
  high-probability set ``{θ : φ > β*}`` is empty; ``λ ∈ [0.95, 0.999]``.

The most confident control ``θ* = argmax μ/σ`` itself is
:meth:`ltamp_cli.learning.model.LevelSetModel.most_confident_control`.
"""

from __future__ import annotations

import math
import numbers

from scipy.special import log_ndtr, ndtri_exp

LAMBDA_RANGE = (0.95, 0.999)


def beta_star(delta: float, index: int | None = None, count: int | None = None) -> float:
    """Corollary 1's threshold for sample ``index`` (1-based) or for each of ``count`` samples.

    With ``count=T`` the uniform choice ``π_i = T`` gives ``sqrt(2 log(T / (2δ)))``; with
    ``index=i`` (an unbounded stream) ``π_i = π² i² / 6`` (``Σ 1/π_i = 1``).
    """
    if not 0.0 < delta < 1.0:
        raise ValueError(f"delta must be in (0, 1), got {delta}")
    if (index is None) == (count is None):
        raise ValueError("give exactly one of index (stream) or count (fixed number of samples)")
    if count is not None:
        if count < 1:
            raise ValueError(f"count must be >= 1, got {count}")
        pi_i = float(count)
    else:
        assert index is not None
        if index < 1:
            raise ValueError(f"index is 1-based, got {index}")
        pi_i = math.pi**2 * index**2 / 6.0
    return math.sqrt(max(2.0 * math.log(pi_i / (2.0 * delta)), 0.0))


def confidence_problem(lam: float, beta: float | None) -> tuple[str, str] | None:
    """``(field, what is wrong)`` with a relaxed-β ``lam`` outside :data:`LAMBDA_RANGE` or a
    non-finite ``beta``, else ``None``: the one check behind ``--lambda``/``--beta`` of the
    CLI, ``world.learned_streams`` settings and :func:`~ltamp_cli.sampling.factory.make_sampler`."""
    if not (_real(lam) and LAMBDA_RANGE[0] <= lam <= LAMBDA_RANGE[1]):
        return "lambda", f"expected a value in [{LAMBDA_RANGE[0]}, {LAMBDA_RANGE[1]}], got {lam}"
    if beta is not None and not (_real(beta) and math.isfinite(beta)):
        return "beta", f"expected a finite number, got {beta}"
    return None


def _real(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def relaxed_beta(phi_star: float, lam: float = 0.95) -> float:
    """``Φ⁻¹(λ Φ(φ*))`` where ``φ*`` is ``μ/σ`` at the most confident control."""
    if not LAMBDA_RANGE[0] <= lam <= LAMBDA_RANGE[1]:
        raise ValueError(f"lambda must be in [{LAMBDA_RANGE[0]}, {LAMBDA_RANGE[1]}], got {lam}")
    # In log space at both ends: log Φ keeps precision when Φ(φ*) is within rounding of 1
    # (large φ*), and Φ⁻¹ of a log keeps it when Φ(φ*) underflows (φ* < -38: a model that
    # saw only failures), where Φ⁻¹(0) = -inf used to admit every control into the set.
    return float(ndtri_exp(math.log(lam) + float(log_ndtr(phi_star))))
