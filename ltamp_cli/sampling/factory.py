"""``make_sampler``: one entry point for every sampler over a model's super-level set."""

from __future__ import annotations

import numpy as np

from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.learning.confidence import confidence_problem
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
    extrapolate: bool = False,
) -> SetSampler:
    """An endless iterator of controls ``(dθ,)`` (physical units) in ``Â_α`` for ``context``.

    ``name``: ``rejection``, ``adaptive``, ``diverse`` (fixed ``kernel``, unit by default) or
    ``diverse-lk`` (``kernel`` learned in place from :meth:`SetSampler.report_unusable`).
    ``beta`` defaults to the relaxed ``Φ⁻¹(lam Φ(φ(θ*)))``; ``is_valid(context, controls)``
    is a hard physical test every yielded control passes. Building the sampler already scores
    ``n_proposals`` uniform controls (``θ*`` and ``β``).

    ``context`` must lie in the skill's context box, the range the model was trained on
    (``ValueError`` naming the values outside it, the message ``ltamp sample --context``
    prints); ``extrapolate=True`` samples there anyway (the GP's mean reverts to its prior
    away from the data, so the set found there is a guess, not something learned).
    """
    if name not in SAMPLER_NAMES:
        raise ValueError(f"unknown sampler {name!r}: expected one of {', '.join(SAMPLER_NAMES)}")
    problem = confidence_problem(lam, beta)  # the limits of `ltamp sample --lambda/--beta`
    if problem is not None:
        raise ValueError(f"{problem[0]}: {problem[1]}")
    if n_proposals < 1 or buffer_size < 1:
        raise ValueError(f"n_proposals and buffer_size must be >= 1, got {n_proposals} and "
                         f"{buffer_size}")
    context = _checked_context(model, context)
    outside = outside_trained_range(model.spec, context)
    if outside and not extrapolate:
        raise ValueError(f"context outside the trained range of skill {model.spec.name!r}: "
                         f"{outside} (pass extrapolate=True to sample there anyway)")
    superlevel = build_superlevel_set(model, context, rng, beta, lam, is_valid, n_proposals)
    if name == "rejection":
        return RejectionSampler(superlevel, rng)
    if name == "adaptive":
        return AdaptiveSampler(superlevel, rng, n=n_proposals, m=buffer_size)
    return DiverseSampler(
        superlevel, rng, kernel=kernel, learn=name == "diverse-lk", n=n_proposals, m=buffer_size
    )


def outside_trained_range(spec: SkillSpec, context: np.ndarray) -> str:
    """``""`` if every value of ``context`` ``(dα,)`` lies in the skill's context box, else
    ``"name=v not in [lo, hi]; ..."`` naming each value outside it. The one check behind
    ``ltamp sample``/``ltamp plot level-set --context``, :func:`make_sampler` and learned
    streams; bounds are inclusive (a value rounded past a bound by 1e-12 of the box's width
    still counts as inside)."""
    values = np.asarray(context, dtype=float).reshape(-1)
    parts = []
    for name, value, lo, hi in zip(spec.context.names, values, spec.context.lows,
                                   spec.context.highs, strict=True):
        slack = 1e-12 * (hi - lo)
        if not lo - slack <= value <= hi + slack:
            shown = [f"{float(v):g}" for v in (value, lo, hi)]
            if shown[0] in shown[1:]:  # 0.5000000001 is no 0.5: print every digit
                shown = [repr(float(v)) for v in (value, lo, hi)]
            parts.append(f"{name}={shown[0]} not in [{shown[1]}, {shown[2]}]")
    return "; ".join(parts)


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
