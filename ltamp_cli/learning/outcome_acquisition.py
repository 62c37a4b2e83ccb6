"""Choosing the next trial of a skill with an outcome by what its outcome will teach (issue #21).

A trial of a skill that declares an :class:`~ltamp_cli.backends.protocol.OutcomeSpec` is
relabelled for every goal (:mod:`~ltamp_cli.learning.outcomes`): once its outcome is seen,
the control's success is known *exactly* for each goal. What the trial teaches is therefore
set by its outcome, not by its own goal, and the straddle ψ = −|μ| + 1.96σ of the score GP
measures the wrong thing: averaged over goals its −|μ| term favours controls whose predicted
score stays near the level for many goals, which on the 2D push are the pushes that leave the
object where it is (score 2 − ‖goal‖: |μ| small for every goal near the circle ‖goal‖ = 2),
the very trials whose outcome is already known (``docs/results/push/README.md``, diagnosis).

:class:`OutcomeModel` fits one GP per outcome value on the trials' outcomes, as a function
of the control and the non-goal context dimensions (normalised inputs, the goal columns
dropped). :func:`propose_by_outcome` scores each candidate control by the expected number of
goals whose success label its outcome resolves: with the outcome drawn from the GPs'
predictive distribution (independent normal per value, ``n_samples`` draws), ``p_g`` is the
share of draws with ``score(goal g, control, outcome) > 0`` and the value is
``mean_g p_g (1 − p_g)`` over ``n_goals`` goals drawn uniformly from the goal box — the
average label variance, zero where the outcome is known or where no plausible outcome changes
a goal's label. The trial's own goal is the drawn goal with the largest ``p_g (1 − p_g)``.

``kind="outcome-sd"`` scores instead by the summed predictive standard deviation of the
outcome's values (plain uncertainty sampling of the outcome map, goal-blind).
``kind="outcome-cover"`` scores by the expected number of goals the trial would reach that
no trial has reached yet (``mean_g p_g · [no recorded outcome scores > 0 at g]``): what θ*
can use, since a goal some training control reached is one θ* can replay. A goal counts as
reached whatever the non-goal context of the trial that reached it (flick2d's friction):
an approximation for skills with such contexts. All three are compared in
``docs/results/push/README.md``; ``outcome-cover`` won on the push and flick2d and is the
default (``LearningConfig.hindsight_acquisition``).

``lse2`` and pool mode choose among *given* candidates (the drawn context's valid controls;
the pool's remaining trials) with :func:`rank_by_outcome`: the same values, each candidate
keeping its own goal as the trial's goal (it does not change the outcome), optionally
weighted in (``LearningConfig.outcome_own_goal_weight``; 0 by default). Measured in
``docs/results/push/README.md``, "lse2 and pool mode".

This module only *chooses* trials; the learned model stays the score GP on the trials and
their relabelled points (what is saved, sampled and used for θ*). The outcome GPs are
refitted from the recorded trials whenever a choice is made, so nothing of them is saved.
"""

from __future__ import annotations

import numpy as np

from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.learning.acquisition import ValidityTest, first_valid
from ltamp_cli.learning.gp import GaussianProcess, HyperBounds, LengthscalePrior, fit_gp
from ltamp_cli.learning.normalize import BoxNormalizer, join_inputs, joint_space

#: Acquisition names of this module (``LearningConfig.hindsight_acquisition``).
OUTCOME_ACQUISITIONS = ("outcome-var", "outcome-sd", "outcome-cover")
#: Goals drawn per choice, and outcome draws per (candidate, goal).
DEFAULT_GOALS = 32
DEFAULT_SAMPLES = 16


class OutcomeModel:
    """Independent GPs from (control, non-goal context) to each outcome value.

    ``fit`` takes the trials in physical units: ``contexts (n, dα)``, ``controls (n, dθ)``,
    ``outcomes (n, d_outcome)``; ``predict`` takes normalised joint inputs ``(m, dθ + dα)``
    (goal columns ignored) and returns ``(mean (m, d_outcome), std (m, d_outcome))`` in the
    outcome's physical units.
    """

    def __init__(self, spec: SkillSpec, gps: list[GaussianProcess],
                 trials: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> None:
        assert spec.outcome is not None
        self.spec = spec
        self.gps = gps
        self.columns = _input_columns(spec)
        #: The trials fitted, physical ``(contexts (n, dα), controls (n, dθ), outcomes)``.
        self.trials = trials

    def covered(self, goals: np.ndarray) -> np.ndarray:
        """``(k,)`` bool: whether some fitted trial's outcome scores > 0 at each goal
        (``goals (k, len(goals))`` normalised; the trial's other context values kept)."""
        assert self.spec.outcome is not None and self.trials is not None
        contexts, controls, outcomes = self.trials
        n, k = len(contexts), len(goals)
        index = np.asarray(self.spec.outcome.goals, dtype=int)
        low = self.spec.context.low_array()[index]
        high = self.spec.context.high_array()[index]
        physical = low + (np.asarray(goals) + 1.0) * 0.5 * (high - low)
        relabelled = np.repeat(contexts, k, axis=0)
        relabelled[:, index] = np.tile(physical, (n, 1))
        scores = self.spec.outcome.scores(relabelled, np.repeat(controls, k, axis=0),
                                          np.repeat(outcomes, k, axis=0))
        return (scores.reshape(n, k) > 0.0).any(axis=0)

    @staticmethod
    def fit(spec: SkillSpec, contexts: np.ndarray, controls: np.ndarray, outcomes: np.ndarray,
            kernel: str = "matern52", rng: np.random.Generator | None = None,
            previous: OutcomeModel | None = None, bounds: HyperBounds | None = None,
            prior: LengthscalePrior | None = None) -> OutcomeModel:
        """Fit every outcome value's GP (warm-started from ``previous`` if given)."""
        if spec.outcome is None:
            raise ValueError(f"skill {spec.name!r} declares no outcome")
        rng = rng if rng is not None else np.random.default_rng(0)
        x = BoxNormalizer.for_space(joint_space(spec)).to_unit(
            join_inputs(spec, contexts, controls))[:, _input_columns(spec)]
        outcomes = np.asarray(outcomes, dtype=float).reshape(len(x), spec.outcome.space.dim)
        gps = []
        for j in range(spec.outcome.space.dim):
            warm = previous.gps[j] if previous is not None else None
            gps.append(fit_gp(x, outcomes[:, j], kernel,
                              restarts=0 if warm is not None else 1, rng=rng,
                              warm_start=warm, bounds=bounds, prior=prior))
        return OutcomeModel(spec, gps, (np.asarray(contexts, dtype=float).reshape(len(x), -1),
                                        np.asarray(controls, dtype=float).reshape(len(x), -1),
                                        outcomes))

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predictive mean and std of the outcome, each ``(m, d_outcome)``."""
        inputs = np.atleast_2d(x)[:, self.columns]
        pairs = [gp.predict(inputs) for gp in self.gps]
        return (np.stack([p[0] for p in pairs], axis=1),
                np.stack([p[1] for p in pairs], axis=1))


def _input_columns(spec: SkillSpec) -> np.ndarray:
    """Joint-input columns the outcome depends on: every control, the non-goal contexts."""
    assert spec.outcome is not None
    goals = set(spec.control.dim + g for g in spec.outcome.goals)
    return np.array([c for c in range(spec.control.dim + spec.context.dim) if c not in goals],
                    dtype=int)


def success_probability(spec: SkillSpec, x: np.ndarray, mean: np.ndarray, std: np.ndarray,
                        goals: np.ndarray, rng: np.random.Generator,
                        n_samples: int = DEFAULT_SAMPLES) -> np.ndarray:
    """``p`` per candidate and goal, ``(m, k)``: the share of ``n_samples``
    outcome draws ``N(mean, std²)`` (each ``(m, d_outcome)``) for which candidate ``x (m, d)``
    (normalised) scores > 0 at goal ``goals (k, len(goals))`` (normalised goal coordinates)."""
    assert spec.outcome is not None
    normalizer = BoxNormalizer.for_space(joint_space(spec))
    m, k = len(x), len(goals)
    goal_columns = spec.control.dim + np.asarray(spec.outcome.goals, dtype=int)
    points = np.repeat(x, k, axis=0)
    points[:, goal_columns] = np.tile(goals, (m, 1))
    physical = normalizer.from_unit(points)
    controls = physical[:, : spec.control.dim]
    contexts = physical[:, spec.control.dim :]
    noise = rng.standard_normal((n_samples, m, mean.shape[1]))
    draws = mean[None] + std[None] * noise  # (s, m, d_outcome)
    draws = np.repeat(draws, k, axis=1).reshape(-1, mean.shape[1])  # (s * m * k, d_outcome)
    scores = spec.outcome.scores(np.tile(contexts, (n_samples, 1)),
                                 np.tile(controls, (n_samples, 1)), draws)
    return (scores.reshape(n_samples, m, k) > 0.0).mean(axis=0)


def propose_by_outcome(
    spec: SkillSpec,
    outcome_model: OutcomeModel,
    rng: np.random.Generator,
    n_candidates: int,
    is_valid: ValidityTest | None,
    kind: str = "outcome-var",
    n_goals: int = DEFAULT_GOALS,
    n_samples: int = DEFAULT_SAMPLES,
) -> np.ndarray | None:
    """The next trial as a normalised joint input ``(d,)`` (module doc), or ``None`` if no
    candidate passes ``is_valid``. ``n_candidates // n_goals`` uniform candidates are scored
    (``n_candidates × n_samples`` score evaluations for ``outcome-var``)."""
    if kind not in OUTCOME_ACQUISITIONS:
        raise ValueError(f"unknown outcome acquisition {kind!r}")
    assert spec.outcome is not None
    dim = spec.control.dim + spec.context.dim
    goal_columns = spec.control.dim + np.asarray(spec.outcome.goals, dtype=int)
    n_controls = max(1, n_candidates // n_goals)
    candidates = rng.uniform(-1.0, 1.0, size=(n_controls, dim))
    goals = rng.uniform(-1.0, 1.0, size=(n_goals, len(goal_columns)))
    values, variance = _values(spec, outcome_model, candidates, goals, rng, kind, n_samples)
    candidates[:, goal_columns] = goals[np.argmax(variance, axis=1)]
    order = np.argsort(-values, kind="stable")
    chosen = first_valid(order, candidates, 1, is_valid)
    if len(chosen) == 0:
        return None
    return candidates[int(chosen[0])]


def _values(spec: SkillSpec, outcome_model: OutcomeModel, candidates: np.ndarray,
            goals: np.ndarray, rng: np.random.Generator, kind: str,
            n_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Each candidate's value under ``kind`` (module doc), ``(m,)``, and its per-goal
    terms ``(m, k)`` (what picks the trial's own goal in :func:`propose_by_outcome`) for the
    normalised ``candidates (m, d)`` and goals ``(k, len(goals))``."""
    mean, std = outcome_model.predict(candidates)
    p = success_probability(spec, candidates, mean, std, goals, rng, n_samples)
    variance = p * (1.0 - p)
    if kind == "outcome-var":
        return variance.mean(axis=1), variance
    if kind == "outcome-sd":
        return std.sum(axis=1), variance
    # outcome-cover: expected number of goals no trial has reached yet
    new = p * ~outcome_model.covered(goals)[None, :]
    return new.mean(axis=1), np.where(new.any(axis=1, keepdims=True), new, variance)


def rank_by_outcome(
    spec: SkillSpec,
    outcome_model: OutcomeModel,
    candidates: np.ndarray,
    rng: np.random.Generator,
    kind: str = "outcome-cover",
    own_goal_weight: float = 0.0,
    n_goals: int = DEFAULT_GOALS,
    n_samples: int = DEFAULT_SAMPLES,
) -> np.ndarray:
    """Values ``(m,)`` of given candidates, normalised joint inputs ``(m, d)`` whose goal
    columns hold each candidate's *own* goal (``lse2``: the drawn goal, the same for all;
    pool mode: each pool trial's goal): ``(1 − w) · value`` over ``n_goals`` goals drawn
    uniformly from the goal box ``+ w · term`` at the candidate's own goal, ``w =
    own_goal_weight`` (``outcome-cover``: ``p`` of reaching the own goal if no trial has
    reached it yet, else 0; ``outcome-var``: ``p (1 − p)`` there; ``outcome-sd`` ignores
    goals). ``w = 0`` (the default) ranks by the drawn goals alone: the outcome, hence what
    the trial teaches, does not depend on the candidate's own goal
    (``docs/results/push/README.md``, "lse2 and pool mode", measures both)."""
    if kind not in OUTCOME_ACQUISITIONS:
        raise ValueError(f"unknown outcome acquisition {kind!r}")
    if not 0.0 <= own_goal_weight <= 1.0:
        raise ValueError(f"own_goal_weight must be in [0, 1], got {own_goal_weight}")
    assert spec.outcome is not None
    candidates = np.atleast_2d(np.asarray(candidates, dtype=float))
    goals = rng.uniform(-1.0, 1.0, size=(n_goals, len(spec.outcome.goals)))
    values, _ = _values(spec, outcome_model, candidates, goals, rng, kind, n_samples)
    if own_goal_weight == 0.0 or kind == "outcome-sd":
        return values
    goal_columns = spec.control.dim + np.asarray(spec.outcome.goals, dtype=int)
    own = candidates[:, goal_columns]
    mean, std = outcome_model.predict(candidates)
    physical = BoxNormalizer.for_space(joint_space(spec)).from_unit(candidates)
    noise = rng.standard_normal((n_samples, *mean.shape))
    draws = (mean[None] + std[None] * noise).reshape(-1, mean.shape[1])  # (s * m, d_outcome)
    scores = spec.outcome.scores(np.tile(physical[:, spec.control.dim:], (n_samples, 1)),
                                 np.tile(physical[:, : spec.control.dim], (n_samples, 1)),
                                 draws)
    p = (scores.reshape(n_samples, len(candidates)) > 0.0).mean(axis=0)
    term = (p * ~outcome_model.covered(own) if kind == "outcome-cover"
            else p * (1.0 - p))
    return (1.0 - own_goal_weight) * values + own_goal_weight * term
