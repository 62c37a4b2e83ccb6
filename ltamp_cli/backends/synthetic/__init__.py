"""Analytic skills whose super-level sets are known: for tests, benchmarks and demos.

``make_backend(noise=0.0)`` returns a :class:`SyntheticBackend` with three skills:

* ``toy1d`` — one control ``theta ∈ [0, 1]``, no context; ``g(θ) = 0.8 sin(3πθ) e^{−θ} − 0.2``
  has two positive intervals (like the paper's level-set figure).
* ``moving2d`` — controls ``x ∈ [0, 4]``, ``y ∈ [−1, 1]``, context ``phase ∈ [0, 1]``. In
  normalised control coordinates ``u`` the good set is a disc of radius ``0.35 + 0.15·phase``
  whose centre moves along an arc with the phase: ``g = 2 (r − ‖u − c(phase)‖)``.
* ``skill8d`` — 4 controls and 4 contexts (``a3`` is irrelevant); the good set is an
  axis-aligned ellipsoid whose centre and size depend on the context
  (``g = 1 − ‖(u − c(α)) / R(α)‖``); controls with
  ``u0 + u1 > 1.2`` fail the hard validity test and score ``−1``.
* ``flick2d`` — a skill with an *outcome* (issue #21): a cue flicks a puck of radius 0.25
  resting at the origin towards a goal. Controls ``offset ∈ [−1, 1]`` (the cue's line passes
  this far beside the puck's centre), ``aim ∈ [0, 2π]`` (the cue's direction), ``power ∈
  [0, 1]``; contexts ``friction ∈ [0.5, 1.5]`` (not a goal: it sets how far the puck slides)
  and the goal ``goal_x, goal_y ∈ [−4, 4]``. A cue that misses the puck (``|offset| ≥
  0.25``: 3/4 of the box) leaves it at the origin; a hit sends it along the line of centres
  (``aim − asin(offset / 0.25)``) a distance ``4 · (power · cos(deflection))² / friction``.
  The outcome is the puck's end position, the score ``1 − ‖end − goal‖``; goals are the
  last two context values. Like the 2D push, most controls do not move the puck and
  success needs the right direction and distance; unlike it the physics depends on a
  non-goal context and is analytic (microseconds per trial). Its trials are deterministic
  (the backend's ``noise`` does not apply to it).

Besides the :class:`~ltamp_cli.backends.protocol.SkillBackend` protocol it exposes
:meth:`SyntheticBackend.true_score`, the vectorised noise-free score used by metrics.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ltamp_cli.backends.protocol import (
    OutcomeSpec,
    ParamSpace,
    SkillSpec,
    TrialResult,
    skill_spec,
)
from ltamp_cli.errors import InputError

# contexts (n, dα), controls (n, dθ), both physical -> scores (n,)
ScoreFunction = Callable[[np.ndarray, np.ndarray], np.ndarray]
ValidityFunction = Callable[[np.ndarray, np.ndarray], np.ndarray]
# contexts (n, dα), controls (n, dθ), both physical -> outcomes (n, d_outcome)
OutcomeFunction = Callable[[np.ndarray, np.ndarray], np.ndarray]


def _unit(values: np.ndarray, space: ParamSpace) -> np.ndarray:
    lows, highs = space.low_array(), space.high_array()
    return 2.0 * (values - lows) / (highs - lows) - 1.0


@dataclass(frozen=True)
class AnalyticSkill:
    spec: SkillSpec
    score: ScoreFunction
    validity: ValidityFunction | None = None
    #: skills with an ``OutcomeSpec``: the outcome of a trial (its score follows from it)
    outcome: OutcomeFunction | None = None


_TOY1D = SkillSpec(
    name="toy1d",
    context=ParamSpace((), (), ()),
    control=ParamSpace(("theta",), (0.0,), (1.0,)),
    description="1-D control toy with two good intervals (paper's level-set figure)",
)


def _toy1d_score(contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
    theta = controls[:, 0]
    return 0.8 * np.sin(3.0 * math.pi * theta) * np.exp(-theta) - 0.2


_MOVING2D = SkillSpec(
    name="moving2d",
    context=ParamSpace(("phase",), (0.0,), (1.0,)),
    control=ParamSpace(("x", "y"), (0.0, -1.0), (4.0, 1.0)),
    description="2 controls + 1 context: a good disc that moves and grows with the phase",
)


def _moving2d_score(contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
    u = _unit(controls, _MOVING2D.control)
    phase = contexts[:, 0]
    center = 0.45 * np.stack([np.cos(math.pi * phase), np.sin(math.pi * phase)], axis=1)
    radius = 0.35 + 0.15 * phase
    return 2.0 * (radius - np.linalg.norm(u - center, axis=1))


_SKILL8D = SkillSpec(
    name="skill8d",
    context=ParamSpace(("a0", "a1", "a2", "a3"), (0.0, 0.0, -1.0, 0.0), (1.0, 2.0, 1.0, 5.0)),
    control=ParamSpace(("c0", "c1", "c2", "c3"), (-1.0, 0.0, 0.0, -2.0), (1.0, 10.0, 1.0, 2.0)),
    description="4 controls + 4 contexts: a context-dependent ellipsoid, one corner invalid",
)
_SKILL8D_MIX = np.array([[0.5, -0.2, 0.1], [0.1, 0.4, -0.3], [-0.3, 0.2, 0.4], [0.2, 0.1, 0.3]])
_SKILL8D_RADII = np.array([0.6, 0.8, 1.0, 1.2])


def _skill8d_score(contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
    u = _unit(controls, _SKILL8D.control)
    a = _unit(contexts, _SKILL8D.context)
    center = a[:, :3] @ _SKILL8D_MIX.T
    radii = _SKILL8D_RADII * (1.0 + 0.25 * a[:, :1])
    return 1.0 - np.linalg.norm((u - center) / radii, axis=1)


def _skill8d_valid(contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
    u = _unit(controls, _SKILL8D.control)
    return u[:, 0] + u[:, 1] <= 1.2


FLICK_RADIUS = 0.25


def _flick2d_outcome(contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """End positions ``(n, 2)`` of the puck (module doc, ``flick2d``)."""
    offset, aim, power = controls[:, 0], controls[:, 1], controls[:, 2]
    hit = np.abs(offset) < FLICK_RADIUS
    deflection = np.arcsin(np.clip(offset / FLICK_RADIUS, -1.0, 1.0))
    distance = np.where(hit, 4.0 * (power * np.cos(deflection)) ** 2 / contexts[:, 0], 0.0)
    direction = aim - deflection
    return np.stack([distance * np.cos(direction), distance * np.sin(direction)], axis=1)


def _flick2d_outcome_score(contexts: np.ndarray, controls: np.ndarray,
                           outcomes: np.ndarray) -> np.ndarray:
    """``1 − ‖end − goal‖`` for batches (goals: context columns 1, 2)."""
    del controls
    return 1.0 - np.linalg.norm(outcomes - contexts[:, 1:3], axis=1)


_FLICK2D = SkillSpec(
    name="flick2d",
    context=ParamSpace(("friction", "goal_x", "goal_y"), (0.5, -4.0, -4.0), (1.5, 4.0, 4.0)),
    control=ParamSpace(("offset", "aim", "power"), (-1.0, 0.0, 0.0), (1.0, 2 * math.pi, 1.0)),
    description="flick a puck to within 1 of a goal; most flicks miss it (outcome: end "
                "position)",
    deterministic=True,
    outcome=OutcomeSpec(
        space=ParamSpace(("puck_x", "puck_y"), (-8.0, -8.0), (8.0, 8.0)),
        score=_flick2d_outcome_score,
        goals=(1, 2),
        achieved_goal=lambda outcomes: np.asarray(outcomes, dtype=float),
    ),
)


def _flick2d_score(contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
    return _flick2d_outcome_score(contexts, controls, _flick2d_outcome(contexts, controls))


def _analytic_skills() -> dict[str, AnalyticSkill]:
    return {
        "toy1d": AnalyticSkill(_TOY1D, _toy1d_score),
        "moving2d": AnalyticSkill(_MOVING2D, _moving2d_score),
        "skill8d": AnalyticSkill(_SKILL8D, _skill8d_score, _skill8d_valid),
        "flick2d": AnalyticSkill(_FLICK2D, _flick2d_score, outcome=_flick2d_outcome),
    }


class SyntheticBackend:
    """Analytic skills; trials cost microseconds. ``noise`` adds seeded N(0, noise²) to scores."""

    name = "synthetic"

    def __init__(self, noise: float = 0.0) -> None:
        if not (noise >= 0.0 and math.isfinite(noise)):
            raise InputError(f"synthetic backend option noise must be >= 0, got {noise!r}")
        self.noise = float(noise)
        self._skills = _analytic_skills()

    def skills(self) -> Mapping[str, SkillSpec]:
        return {name: skill.spec for name, skill in self._skills.items()}

    def _skill(self, skill: str) -> AnalyticSkill:
        skill_spec(self, skill)  # raises a KeyError naming the known skills
        return self._skills[skill]

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        return self._skill(skill).spec.context.sample_uniform(rng, 1)[0]

    def _batch(
        self, skill: str, contexts: np.ndarray, controls: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        spec = self._skill(skill).spec
        controls = np.asarray(controls, dtype=float).reshape(-1, spec.control.dim)
        contexts = np.asarray(contexts, dtype=float)
        if contexts.ndim <= 1:
            contexts = np.broadcast_to(contexts.reshape(1, -1), (len(controls), spec.context.dim))
        return contexts.reshape(len(controls), spec.context.dim), controls

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        contexts, controls = self._batch(skill, context, controls)
        validity = self._skill(skill).validity
        if validity is None:
            return np.ones(len(controls), dtype=bool)
        return np.asarray(validity(contexts, controls), dtype=bool)

    def true_score(self, skill: str, contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
        """Noise-free scores ``(n,)`` for physical ``contexts (n, dα)`` (or one ``(dα,)``) and
        ``controls (n, dθ)``; invalid controls get the skill's invalid score."""
        contexts, controls = self._batch(skill, contexts, controls)
        analytic = self._skill(skill)
        scores = analytic.score(contexts, controls)
        if analytic.validity is not None:
            scores = np.where(
                analytic.validity(contexts, controls), scores, analytic.spec.invalid_score
            )
        return scores

    def run_trial(
        self, skill: str, context: np.ndarray, control: np.ndarray, seed: int
    ) -> TrialResult:
        valid = bool(self.is_valid(skill, context, control)[0])
        if not valid:
            return TrialResult(score=self._skill(skill).spec.invalid_score, valid=False)
        analytic = self._skill(skill)
        if analytic.outcome is not None:  # deterministic: noise does not apply
            contexts, controls = self._batch(skill, context, control)
            outcome = analytic.outcome(contexts, controls)[0]
            score = float(analytic.score(contexts, controls)[0])
            return TrialResult(score=score, valid=True,
                               outcome=tuple(float(v) for v in outcome))
        score = float(self.true_score(skill, context, control)[0])
        if self.noise > 0.0:
            score += self.noise * float(np.random.default_rng(seed).standard_normal())
        return TrialResult(score=score, valid=True)

    def close(self) -> None:
        """Nothing to release."""


def make_backend(**options: Any) -> SyntheticBackend:
    """Factory used by :func:`ltamp_cli.backends.load_backend` (option: ``noise``)."""
    unknown = set(options) - {"noise"}
    if unknown:
        raise InputError(f"unknown synthetic backend option(s): {', '.join(sorted(unknown))}")
    return SyntheticBackend(**options)
