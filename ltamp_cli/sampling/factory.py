"""``make_sampler``: one entry point for every sampler over a model's super-level set."""

from __future__ import annotations

import numpy as np

from ltamp_cli.learning.model import SkillModel
from ltamp_cli.sampling.adaptive import DEFAULT_BUFFER, AdaptiveSampler
from ltamp_cli.sampling.base import SetSampler
from ltamp_cli.sampling.diverse import DiverseSampler
from ltamp_cli.sampling.kernel_learning import DiversityKernel
from ltamp_cli.sampling.rejection import RejectionSampler
from ltamp_cli.sampling.superlevel import (
    DEFAULT_LAMBDA,
    DEFAULT_PROPOSALS,
    PhysicalValidity,
    build_superlevel_set,
)

SAMPLER_NAMES = ("rejection", "adaptive", "diverse", "diverse-lk")


def make_sampler(
    name: str,
    model: SkillModel,
    context: np.ndarray,
    rng: np.random.Generator,
    beta: float | None = None,
    is_valid: PhysicalValidity | None = None,
    *,
    lam: float = DEFAULT_LAMBDA,
    kernel: DiversityKernel | None = None,
    n_proposals: int = DEFAULT_PROPOSALS,
    buffer_size: int = DEFAULT_BUFFER,
) -> SetSampler:
    """An endless iterator of controls ``(dθ,)`` (physical units) in ``Â_α`` for ``context``.

    ``name``: ``rejection``, ``adaptive``, ``diverse`` (fixed ``kernel``, unit by default) or
    ``diverse-lk`` (``kernel`` learned in place from :meth:`SetSampler.report_unusable`).
    ``beta`` defaults to the relaxed ``Φ⁻¹(lam Φ(φ(θ*)))``; ``is_valid(context, controls)``
    is a hard physical test every yielded control passes. Building the sampler already scores
    ``n_proposals`` uniform controls (``θ*`` and ``β``).
    """
    if name not in SAMPLER_NAMES:
        raise ValueError(f"unknown sampler {name!r}: expected one of {', '.join(SAMPLER_NAMES)}")
    context = _checked_context(model, context)
    superlevel = build_superlevel_set(model, context, rng, beta, lam, is_valid, n_proposals)
    if name == "rejection":
        return RejectionSampler(superlevel, rng)
    if name == "adaptive":
        return AdaptiveSampler(superlevel, rng, n=n_proposals, m=buffer_size)
    return DiverseSampler(
        superlevel, rng, kernel=kernel, learn=name == "diverse-lk", n=n_proposals, m=buffer_size
    )


def _checked_context(model: SkillModel, context: np.ndarray) -> np.ndarray:
    """``context`` as a ``(dα,)`` float array; ``ValueError`` naming the skill's context
    when its length is wrong or a value is NaN/inf (a NaN context used to give an empty
    sampler without a word, a wrong length a numpy reshape error)."""
    names = model.spec.context.names
    values = np.asarray(context, dtype=float).reshape(-1)
    if len(values) != len(names):
        raise ValueError(f"context has {len(values)} value(s), skill {model.spec.name!r} has "
                         f"{len(names)} ({', '.join(names) or 'none'})")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"context {values.tolist()} of skill {model.spec.name!r} is not finite")
    return values
