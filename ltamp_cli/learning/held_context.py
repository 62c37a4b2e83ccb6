"""Straddle queries on a held context: the paper's Algorithm 1 run several times per context.

The paper (section 4.1) selects training contexts from the skill's context distribution and,
*for each context*, applies the straddle to choose controls; the reference learner
(zi-w/Kitchen2D ``run_ActiveLearner``) queries one fixed context over and over. ``lse`` here
instead maximises ψ over control *and* context, and ``lse2`` draws a fresh context for every
trial. :class:`HeldContext` is the in-between, used by ``lse`` when
``LearningConfig.context_repeats = k > 0``: a context drawn from the distribution is kept for
``k`` consecutive trials, each control maximising ψ for it continuously (random candidates,
then L-BFGS-B, like ``lse``), then the next context is drawn.

Why (issue #21, 2D push): when a context alone explains the level set for most controls (the
push's goal within 2 of the object succeeds whatever the pusher does, unless it touches the
object), the joint straddle keeps choosing contexts on that context-only boundary, where a
trial says nothing about the controls; and one query per fresh context never climbs towards
a rare success set (a needle in the control box). On a held context ψ = −|μ| + 1.96σ, with
μ < 0 everywhere, is an upper confidence bound on the score, so successive queries climb
towards the context's successes — provided the GP does not call the controls irrelevant.
Measured (``docs/results/learning/README.md``, push section): with the default GP fit it
changed nothing on the push; with the reference's short lengthscales it gained 0.05 there
and lost 0.2–0.4 on the pour and two synthetic skills. An option, not a default.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.learning.acquisition import maximize, straddle
from ltamp_cli.learning.model import LevelSetModel, PhysicalValidity

# rng -> one physical context (dα,)
ContextSampler = Callable[[np.random.Generator], np.ndarray]


class HeldContext:
    """Draws a context every ``repeats`` proposals and proposes ψ-maximising controls for it.

    State: the held context ``(dα,)`` and how many proposals it has left (not persisted: a
    resumed run draws a new context).
    """

    def __init__(self, spec: SkillSpec, repeats: int, sample_context: ContextSampler) -> None:
        if repeats < 1:
            raise ValueError(f"repeats must be >= 1, got {repeats}")
        self.spec = spec
        self.repeats = repeats
        self.sample_context = sample_context
        self.context: np.ndarray | None = None
        self.left = 0

    def propose(
        self,
        model: LevelSetModel,
        rng: np.random.Generator,
        is_valid: PhysicalValidity | None,
        n_candidates: int,
        n_restarts: int,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Next ``(context (dα,), control (dθ,))`` in physical units; a uniform control if no
        candidate passes ``is_valid``."""
        if self.context is None or self.left <= 0:
            self.context = np.asarray(self.sample_context(rng), dtype=float).reshape(
                self.spec.context.dim
            )
            self.left = self.repeats
        self.left -= 1
        context = self.context
        dc = self.spec.control.dim
        fixed = np.zeros(model.dim)
        fixed[dc:] = model._context_unit(context)
        best = maximize(
            model.gp,
            straddle,
            rng,
            fixed=fixed,
            free=np.arange(model.dim) < dc,
            n_candidates=n_candidates,
            n_restarts=n_restarts,
            is_valid=model.validity_test(is_valid),
        )
        if best is None:
            return context, self.spec.control.sample_uniform(rng, 1)[0]
        return context, model.from_unit(best.x)[1][0]
