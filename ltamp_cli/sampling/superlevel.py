"""The high-probability super-level set ``Â_α = {θ ∈ B : μ(θ, α)/σ(θ, α) > β}`` of a GP model.

Everything is in normalised control coordinates ``u ∈ B = [-1, 1]^dθ`` (``Vol(B) = 2^dθ``);
:meth:`SuperLevelSet.to_physical` maps back. Membership is vectorised and chunked: means come
first and, when ``β ≥ 0``, the variance is computed only for controls with ``μ > 0`` (the others
cannot pass). A hard validity test (physical units), if given, is part of membership, so every
sample drawn from the set passes it.

:func:`build_superlevel_set` also finds ``θ*`` (the most confident control, ``argmax μ/σ``
over ``n`` uniform controls — the paper's sampling estimate) and, unless ``β`` is given, the
relaxed threshold ``β = Φ⁻¹(λ Φ(φ(θ*)))``. The uniform batch it scores is kept
(:attr:`SuperLevelSet.seed_members`) so samplers can use its members as their first uniform
proposals instead of scoring another batch.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ltamp_cli.learning.confidence import relaxed_beta
from ltamp_cli.learning.model import LevelSetModel, SkillModel
from ltamp_cli.sampling.posterior import ContextPosterior

# physical validity test: (context (dα,), controls (n, dθ)) -> bool (n,)
PhysicalValidity = Callable[[np.ndarray, np.ndarray], np.ndarray]

DEFAULT_LAMBDA = 0.95
DEFAULT_PROPOSALS = 10_000
CHUNK = 4096


@dataclass
class SuperLevelSet:
    """``Â_α`` for one model, one physical ``context (dα,)`` and threshold ``beta``.

    ``theta_star (dθ,)`` (normalised) is the most confident valid control found and
    ``phi_star`` its ``μ/σ``; ``seed_members (k, dθ)`` are the members of the uniform batch
    scored while building the set, ``θ*`` excepted (consumed once by :meth:`take_seed_members`).
    """

    model: LevelSetModel
    context: np.ndarray
    beta: float
    is_valid: PhysicalValidity | None = None
    theta_star: np.ndarray | None = None
    phi_star: float = float("nan")
    seed_members: np.ndarray | None = None
    posterior: ContextPosterior = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.context = np.asarray(self.context, dtype=float).reshape(self.model.spec.context.dim)
        dummy = np.zeros((1, self.dim))
        context_unit = self.model.to_unit(self.context, dummy)[0, self.dim :]
        self.posterior = ContextPosterior(self.model, context_unit)

    @property
    def dim(self) -> int:
        """Number of controls ``dθ``."""
        return self.model.spec.control.dim

    @property
    def volume(self) -> float:
        """``Vol(B)`` of the normalised control box."""
        return 2.0**self.dim

    def to_physical(self, u: np.ndarray) -> np.ndarray:
        """Normalised controls ``(n, dθ)`` -> physical ``(n, dθ)``."""
        u = np.asarray(u, dtype=float).reshape(-1, self.dim)
        return self.model.from_unit(self.posterior.full_inputs(u))[1]

    def to_unit(self, controls: np.ndarray) -> np.ndarray:
        """Physical controls ``(n, dθ)`` -> normalised ``(n, dθ)``."""
        controls = np.asarray(controls, dtype=float).reshape(-1, self.dim)
        return self.model.to_unit(self.context, controls)[:, : self.dim]

    def ratio(self, u: np.ndarray) -> np.ndarray:
        """``μ/σ (n,)`` at normalised controls ``u (n, dθ)``."""
        mean, std = self.posterior.predict(np.asarray(u, dtype=float).reshape(-1, self.dim))
        return mean / std

    def _valid(self, u: np.ndarray) -> np.ndarray:
        if self.is_valid is None or len(u) == 0:
            return np.ones(len(u), dtype=bool)
        return np.asarray(self.is_valid(self.context, self.to_physical(u)), dtype=bool)

    def contains(self, u: np.ndarray) -> np.ndarray:
        """Membership ``(n,)`` bool: ``μ/σ > β`` and the validity test, for ``u (n, dθ)``."""
        u = np.asarray(u, dtype=float).reshape(-1, self.dim)
        inside = np.zeros(len(u), dtype=bool)
        for start in range(0, len(u), CHUNK):
            block = u[start : start + CHUNK]
            mean, cross = self.posterior.mean_and_cross(block)
            # σ > 0, so with β ≥ 0 only μ > 0 can pass: skip the variance of the rest.
            rows = np.flatnonzero(mean > 0.0) if self.beta >= 0.0 else np.arange(len(block))
            if len(rows) == 0:
                continue
            std = self.posterior.std(block[rows], None if cross is None else cross[rows])
            passed = rows[mean[rows] / std > self.beta]
            if len(passed):
                passed = passed[self._valid(block[passed])]
            inside[start + passed] = True
        return inside

    def take_seed_members(self) -> np.ndarray | None:
        """The seed batch's members (uniform draws inside the set), once; then ``None``."""
        members, self.seed_members = self.seed_members, None
        return members


def _ratios_for_argmax(posterior: ContextPosterior, u: np.ndarray) -> np.ndarray:
    """``μ/σ`` where it can be the maximum, ``-inf`` elsewhere (``μ ≤ 0`` when some ``μ > 0``)."""
    mean, cross = posterior.mean_and_cross(u)
    rows = np.flatnonzero(mean > 0.0)
    if len(rows) == 0:
        rows = np.arange(len(u))
    ratios = np.full(len(u), -np.inf)
    ratios[rows] = mean[rows] / posterior.std(u[rows], None if cross is None else cross[rows])
    return ratios


def build_superlevel_set(
    model: SkillModel,
    context: np.ndarray,
    rng: np.random.Generator,
    beta: float | None = None,
    lam: float = DEFAULT_LAMBDA,
    is_valid: PhysicalValidity | None = None,
    n_candidates: int = DEFAULT_PROPOSALS,
) -> SuperLevelSet:
    """``Â_α`` for physical ``context (dα,)``; ``β`` relaxed with ``lam`` unless given.

    ``θ*`` is the valid control with the largest ``μ/σ`` among ``n_candidates`` uniform ones
    (if none is valid, the largest overall).
    """
    if not isinstance(model, LevelSetModel):
        raise TypeError(f"samplers need a GP level-set model, not a {model.kind!r} model")
    context = np.asarray(context, dtype=float).reshape(model.spec.context.dim)
    probe = SuperLevelSet(model, context, 0.0, is_valid)
    u = rng.uniform(-1.0, 1.0, size=(n_candidates, probe.dim))
    ratios = np.concatenate([
        _ratios_for_argmax(probe.posterior, u[s : s + CHUNK]) for s in range(0, len(u), CHUNK)
    ])
    order = np.argsort(-ratios, kind="stable")
    star = order[0]
    if is_valid is not None:
        for start in range(0, len(order), 256):
            block = order[start : start + 256]
            ok = probe._valid(u[block])
            if ok.any():
                star = block[int(np.argmax(ok))]
                break
    phi_star = float(ratios[star])
    if beta is None:
        beta = relaxed_beta(phi_star, lam)
    passed = np.flatnonzero(ratios > beta)
    # θ* is left out: samplers that start from it add it themselves, and a pool holding it
    # twice could hand out the same control twice.
    passed = passed[passed != star]
    passed = passed[probe._valid(u[passed])]
    return SuperLevelSet(
        model,
        context,
        float(beta),
        is_valid,
        theta_star=u[star].copy(),
        phi_star=phi_star,
        seed_members=u[np.sort(passed)],
    )
