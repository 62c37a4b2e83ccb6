"""Learning from trial outcomes: hindsight relabelling (issue #21).

A skill that declares an outcome (:class:`~ltamp_cli.backends.protocol.OutcomeSpec`: what its
trial observes, the score as a function of ``(context, control, outcome)``, and which context
dimensions are goals the physics ignores) tells the learner far more per trial than one score:
the same control with the same outcome would have scored *exactly*
``score(context', control, outcome)`` for any context ``context'`` that differs only in its
goals. :class:`Relabeller` turns each trial into extra training points of that kind:

* the *achieved* goal (``OutcomeSpec.achieved_goal``, if declared, e.g. where the push left
  the object), clipped to the goal box: a success at a goal the trial's own score could not
  reveal;
* ``goals_per_trial`` goals drawn uniformly from the goal box (the skill's context bounds),
  which show where the same control fails.

The learners then fit their model (GP, network) to the real trials plus the relabelled points;
everything downstream is unchanged — θ* is ``argmax μ/σ`` on that GP (``lse`` chooses the
next trial with a GP on the outcomes by default,
:mod:`~ltamp_cli.learning.outcome_acquisition`; :func:`propose_for_all_goals` is the
goal-averaged straddle it replaced), and a learned stream samples from the saved GP
without refitting. The relabelled points are *exact* scores of the real control (no model
in between), so a deterministic skill's noise cap still applies.

**Size.** Relabelled points multiply the data (``1 + goals_per_trial`` per trial). The GP sees
every real trial, every achieved-goal point and at most ``cap`` relabelled points in all: past
the cap, the relabelled points kept are those with the smallest priority key (achieved-goal
points first, then drawn ones; keys are uniform draws from the relabeller's own seeded
stream, fixed when a point is made), so the kept set is a uniform subsample of the drawn
goals that changes little from one trial to the next. 100 push trials with the defaults
(4 drawn goals, cap 300): a GP of 100 real + 300 relabelled points.

**Why relabelling rather than an outcome model.** The alternative — a GP from the non-goal
context and the control to the outcome, with P(score ≥ 0) computed by propagating its
predictive distribution through the score function — needs a multi-output model, a
sampling or moment-matching step inside every acquisition and θ* evaluation, and a new model
kind in saved model directories and learned streams. Relabelling keeps the one-GP-on-the-score
model the straddle, θ*, model directories and streams already use, and its points are exact.
It was the only variant built and measured in the time available (issue #21's push
measurements: ``docs/results/learning/README.md``, "Outcomes"); the outcome model was not.

No draws are made for skills without an outcome, and the relabeller's random stream is its
own (seeded from the learner's seed), so a skill that declares none learns bit-identically to
before and the trials a learner draws at random are the same with or without relabelling.
"""

from __future__ import annotations

import logging

import numpy as np

from ltamp_cli.backends.protocol import OutcomeSpec, SkillSpec
from ltamp_cli.learning.acquisition import ValidityTest, evaluate, first_valid, straddle
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.learning.normalize import BoxNormalizer, join_inputs, joint_space

LOGGER = logging.getLogger("ltamp")

#: Default number of goals drawn from the goal box per trial (besides the achieved goal).
DEFAULT_GOALS_PER_TRIAL = 4
#: Default largest number of relabelled points in the training set (real trials excluded).
DEFAULT_CAP = 300
#: Salt of the relabeller's random stream (``default_rng([seed, SALT])``).
SALT = 21


class Relabeller:
    """Relabelled training points of a skill with a declared outcome (module doc).

    ``add`` takes one trial in physical units; ``arrays`` returns the kept points as
    normalised GP inputs ``(m, d)`` (order ``[control..., context...]``) and scores ``(m,)``.
    """

    def __init__(self, spec: SkillSpec, goals_per_trial: int = DEFAULT_GOALS_PER_TRIAL,
                 cap: int = DEFAULT_CAP, seed: int = 0) -> None:
        if spec.outcome is None:
            raise ValueError(f"skill {spec.name!r} declares no outcome: nothing to relabel")
        if goals_per_trial < 0 or cap < 0:
            raise ValueError(f"goals_per_trial and cap must be >= 0, got {goals_per_trial} "
                             f"and {cap}")
        self.spec = spec
        self.outcome: OutcomeSpec = spec.outcome
        self.goals_per_trial = goals_per_trial
        self.cap = cap
        self.rng = np.random.default_rng([seed, SALT])
        self.normalizer = BoxNormalizer.for_space(joint_space(spec))
        index = np.asarray(self.outcome.goals, dtype=int)
        self._goals = index
        self._low = spec.context.low_array()[index]
        self._high = spec.context.high_array()[index]
        self._x: list[np.ndarray] = []
        self._y: list[np.ndarray] = []
        self._keys: list[np.ndarray] = []
        #: The trials themselves, physical units: ``(context, control, outcome)`` each.
        self.trials: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._warned: set[str] = set()
        self._achieved_kept = False  # whether the last relabel's first point is the achieved goal

    @property
    def size(self) -> int:
        """Relabelled points made so far (before the cap)."""
        return sum(len(y) for y in self._y)

    def relabel(self, context: np.ndarray, control: np.ndarray,
                outcome: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One trial's relabelled points in physical units: ``(contexts (m, dα), controls
        (m, dθ), exact scores (m,))``; the achieved goal (if declared) first. Draws
        ``goals_per_trial`` goals from the relabeller's stream."""
        context = np.asarray(context, dtype=float).reshape(self.spec.context.dim)
        control = np.asarray(control, dtype=float).reshape(self.spec.control.dim)
        outcome = np.asarray(outcome, dtype=float).reshape(self.outcome.space.dim)
        goals = []
        self._achieved_kept = False
        if self.outcome.achieved_goal is not None:
            achieved = self._achieved(outcome)
            if achieved is not None:
                goals.append(np.clip(achieved, self._low, self._high))
                self._achieved_kept = True
        if self.goals_per_trial:
            goals.extend(self.rng.uniform(self._low, self._high,
                                          size=(self.goals_per_trial, len(self._goals))))
        contexts = np.repeat(context[None, :], len(goals), axis=0)
        if goals:
            contexts[:, self._goals] = np.asarray(goals)
        controls = np.repeat(control[None, :], len(goals), axis=0)
        outcomes = np.repeat(outcome[None, :], len(goals), axis=0)
        if not goals:
            return contexts, controls, np.zeros(0)
        try:
            scores = self.outcome.scores(contexts, controls, outcomes)
        except Exception:  # a plugin's function: keep the goals it can score
            keep, scores = self._scores_one_by_one(contexts, controls, outcomes)
            self._achieved_kept = self._achieved_kept and bool(keep[0])
            contexts, controls = contexts[keep], controls[keep]
        return contexts, controls, scores

    def _achieved(self, outcome: np.ndarray) -> np.ndarray | None:
        """The declared achieved goal of one outcome, ``None`` (and one warning) when the
        skill's function fails, gives the wrong shape or non-finite values."""
        assert self.outcome.achieved_goal is not None
        try:
            achieved = np.asarray(self.outcome.achieved_goal(outcome[None, :]),
                                  dtype=float).reshape(len(self._goals))
            if not np.isfinite(achieved).all():
                raise ValueError(f"non-finite goal {achieved.tolist()}")
        except Exception as error:
            self._warn("achieved_goal", error)
            return None
        return achieved

    def _scores_one_by_one(self, contexts: np.ndarray, controls: np.ndarray,
                           outcomes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The rows the declared score function scores (finite), and their scores."""
        keep = np.zeros(len(contexts), dtype=bool)
        scores = []
        for row in range(len(contexts)):
            try:
                value = self.outcome.scores(contexts[row:row + 1], controls[row:row + 1],
                                            outcomes[row:row + 1])
            except Exception as error:
                self._warn("score function", error)
                continue
            keep[row] = True
            scores.append(float(value[0]))
        return keep, np.asarray(scores, dtype=float)

    def _warn(self, function: str, error: Exception) -> None:
        """One warning per relabeller and function: those relabelled points are left out
        (raising would end the training after the trial was saved, and every resume would
        relabel the same trial and end again)."""
        if function in self._warned:
            return
        self._warned.add(function)
        message = " ".join(f"{type(error).__name__}: {error}".split())[:200]
        LOGGER.warning("ltamp: warning: skill %r: the declared outcome %s failed on a "
                       "relabelled goal (%s); the points it cannot give are left out",
                       self.spec.name, function, message)

    def add(self, context: np.ndarray, control: np.ndarray, outcome: np.ndarray) -> None:
        """Relabel one trial (physical units) and keep its points."""
        contexts, controls, scores = self.relabel(context, control, outcome)
        self.trials.append((np.asarray(context, dtype=float), np.asarray(control, dtype=float),
                            np.asarray(outcome, dtype=float)))
        keys = self.rng.random(len(scores))
        if self._achieved_kept and len(keys):
            keys[0] -= 1.0  # achieved-goal points are kept before drawn ones
        self._x.append(self.normalizer.to_unit(join_inputs(self.spec, contexts, controls)))
        self._y.append(scores)
        self._keys.append(keys)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The kept relabelled points (at most ``cap``, in the order they were made):
        normalised inputs ``(m, d)`` and scores ``(m,)``."""
        dim = self.spec.control.dim + self.spec.context.dim
        if not self._y:
            return np.zeros((0, dim)), np.zeros(0)
        x, y = np.concatenate(self._x), np.concatenate(self._y)
        if len(y) > self.cap:
            keys = np.concatenate(self._keys)
            keep = np.sort(np.argsort(keys, kind="stable")[: self.cap])
            x, y = x[keep], y[keep]
        return x, y


#: Goals per control candidate over which :func:`propose_for_all_goals` averages ψ.
ACQUISITION_GOALS = 8


def propose_for_all_goals(
    model: LevelSetModel,
    rng: np.random.Generator,
    n_candidates: int,
    is_valid: ValidityTest | None,
    n_goals: int = ACQUISITION_GOALS,
) -> tuple[np.ndarray, np.ndarray] | None:
    """The next ``(context (dα,), control (dθ,))`` (physical units) for a skill whose trials
    are relabelled: the control (with the non-goal context dimensions) whose straddle ψ,
    *averaged over* ``n_goals`` goals drawn uniformly from the goal box, is largest; the
    trial's own goal is the one of those with the largest ψ for it. ``None`` if no candidate
    passes ``is_valid``.

    Why averaged: the outcome does not depend on the goal, and every trial is relabelled for
    many goals, so a trial informs the level set of *every* goal; the joint straddle over
    (control, goal) instead picks single points of the boundary, and on the 2D push those
    are the circle ‖goal‖ = 2 where a push that never touches the object decides success
    (``docs/results/learning/README.md``, "Outcomes"). ``n_candidates // n_goals`` uniform
    candidates are scored (about ``n_candidates`` GP predictions), no gradient refinement.
    """
    spec = model.spec
    assert spec.outcome is not None
    d_control = spec.control.dim
    goal_columns = d_control + np.asarray(spec.outcome.goals, dtype=int)
    n_controls = max(1, n_candidates // n_goals)
    candidates = rng.uniform(-1.0, 1.0, size=(n_controls, model.dim))
    goals = rng.uniform(-1.0, 1.0, size=(n_goals, len(goal_columns)))
    points = np.repeat(candidates, n_goals, axis=0)
    points[:, goal_columns] = np.tile(goals, (n_controls, 1))
    psi = evaluate(model.gp, straddle, points).reshape(n_controls, n_goals)
    best_goal = np.argmax(psi, axis=1)
    candidates[:, goal_columns] = goals[best_goal]
    order = np.argsort(-psi.mean(axis=1), kind="stable")
    chosen = first_valid(order, candidates, 1, is_valid)
    if len(chosen) == 0:
        return None
    contexts, controls = model.from_unit(candidates[int(chosen[0])][None, :])
    return contexts[0], controls[0]
