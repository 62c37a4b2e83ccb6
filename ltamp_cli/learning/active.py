"""Learning loops: active level-set estimation (Algorithm 1) and the baselines' data collection.

Strategies (``LearningConfig.strategy``):

* ``lse`` — GP; each query maximises the straddle ψ over control *and* context;
* ``lse2`` — GP; the context is drawn from the skill's context distribution, the control
  is the one with the largest ψ among ``lse2_candidates`` uniform controls that pass the
  pre-check for it (the paper's discrete GP-LSE2, section 6.2, which picks the pool trial
  with the largest ψ among those of a sampled bowl–cup pair; see below); for a skill with
  an outcome, the one of largest outcome value (``hindsight_acquisition``, as ``lse``;
  :func:`_outcome_choice`), ψ breaking ties;
* ``gp`` — GP on uniformly random trials (no active learning);
* ``random`` — uniformly random trials, no model (:class:`~.baselines.RandomModel`);
* ``nn-c``, ``nn-r``, ``rf-c``, ``rf-r`` — scikit-learn baselines on uniformly random trials.

The first ``init`` trials are always random, and so is every trial until one has scored above
the level (``explore_until_success``): with no super-level point observed the GP's posterior
mean lies below the level everywhere, so the straddle ψ has no boundary to refine and reduces
to maximising σ, which the box's corners win — for physical skills those are extreme controls,
worse than uniform ones (2D pour, seeds 0 and 2: 1 and 0 successes in 75 straddle trials
where uniform ones find ~1 in 10).

``lse2`` does not refine its choice by gradient ascent inside the control box, as ``lse`` does:
each drawn context is new, so its control slice is unexplored and ψ there is dominated by σ,
which grows towards the box's corners; maximised continuously, ψ put 43 of 47 choices on the
control box's boundary on the 2D pour (seed 0, issue #21; the corners all failed, and with only
failures there the GP's control lengthscales rose to their upper bound, so the next slice
looked unexplored too: 1 success in 47 straddle trials). Among 100 uniform valid controls the
choice stays in the body of the box unless ψ really singles out an edge (seed 0: 9 of 47 on the
boundary, 13 successes; seed 1: 11 of 50).

When ψ ≤ 0 for *every* candidate of the drawn context (each is classified at 95 %: the GP is
sure no control of this context reaches the level, or sure they all do), the straddle has no
boundary to refine in the slice and its argmax is merely the largest σ — the candidate farthest
from the data, near the box's edges. That is how ``lse2`` stalled after one early success
explained by the context alone (synthetic ``saturated4d``, seed 7, issue #21): the fit put a
context lengthscale at ~0.09 and the outputscale at its lower bound (σ_f ≈ 0.22 score units
against a mean of −0.93, so 1.96 σ_f < |mean|: nothing unexplored could reach the level), ψ ≤ 0
held on 83 of 87 drawn contexts, the σ-ranked choices sat near the corners and found no second
success in 88 trials, so the fit never recovered. ``lse2`` then takes a uniform valid control
instead (``lse2_uniform_if_classified``), as ``explore_until_success`` does before the first
success: same candidates, same random draws, so runs whose slices always hold an unclassified
candidate are unchanged. ``budget`` counts all trials. After every trial the
GP is conditioned on the new data; its hyperparameters are re-optimised (warm-started) after
every trial up to ``dense_refit`` trials and every ``refit_every`` trials after that, and fully
(with random restarts) at the end. Online learning runs live trials through a
:class:`~ltamp_cli.backends.protocol.SkillBackend`, appending each to a
:class:`~ltamp_cli.trials.TrialDataset` so that an interrupted run resumes; *pool* learning
replays a dataset of pre-collected trials, picking each next trial without replacement (the
paper's discrete active learning, section 6.2).
"""

from __future__ import annotations

import logging
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from ltamp_cli.backends.protocol import (
    SkillBackend,
    SkillSpec,
    drawn_context,
    skill_spec,
    trial_setup,
)
from ltamp_cli.backends.sanity import run_trial_safely
from ltamp_cli.errors import InputError, location_in
from ltamp_cli.learning.acquisition import evaluate, maximize, straddle
from ltamp_cli.learning.baselines import SKLEARN_KINDS, RandomModel, SklearnModel
from ltamp_cli.learning.defaults import DEFAULT_STRATEGY
from ltamp_cli.learning.gp import DEFAULT_PRIOR, HyperBounds, LengthscalePrior, fit_gp
from ltamp_cli.learning.held_context import HeldContext
from ltamp_cli.learning.kernels import KERNEL_NAMES
from ltamp_cli.learning.metrics import Evaluation, SkillEvaluator
from ltamp_cli.learning.model import LevelSetModel, PhysicalValidity, SkillModel
from ltamp_cli.learning.outcome_acquisition import (
    DEFAULT_GOALS,
    OUTCOME_ACQUISITIONS,
    OutcomeModel,
    propose_by_outcome,
    rank_by_outcome,
)
from ltamp_cli.learning.outcomes import (
    DEFAULT_CAP,
    DEFAULT_GOALS_PER_TRIAL,
    Relabeller,
    propose_for_all_goals,
)
from ltamp_cli.seeds import usable_seed
from ltamp_cli.threads import limits_threads
from ltamp_cli.trials.physics import TrialKind, backend_physics, check_physics, check_trial_kind
from ltamp_cli.trials.record import (
    TrialDataset,
    TrialRecord,
    check_against_spec,
    setup_words,
    training_score,
    without_duplicates,
)
from ltamp_cli.writer_lock import exclusive_writer

#: Upper bound of the GP's noise variance (in RMS-scaled score units) for a skill whose
#: trials are deterministic (:attr:`SkillSpec.deterministic`); others keep
#: ``HyperBounds().noise``. Measured on the 2D push's 300 shipped trials (issue #20):
#: with the default bound 0.5 the marginal likelihood's best fit put the angle's lengthscale
#: at its upper bound (angle "irrelevant") and explained the needle-shaped success set as
#: noise (σ_n = 1.76 score units, though the push has no randomness); θ* then succeeded for
#: 13 of 40 goals over the box. Capped at 0.01 the fit uses the angle (lengthscale 0.10)
#: and θ* succeeded for 30 of 40.
DETERMINISTIC_NOISE = 0.01

HINDSIGHT_ACQUISITIONS = ("goal-mean", "joint", *OUTCOME_ACQUISITIONS)
STRATEGIES = ("lse", "lse2", "gp", "random", *SKLEARN_KINDS)
ACTIVE_STRATEGIES = ("lse", "lse2")
GP_STRATEGIES = ("lse", "lse2", "gp")


@dataclass(frozen=True)
class LearningConfig:
    """How to learn. ``budget`` is the total number of trials, ``init`` of them random."""

    strategy: str = DEFAULT_STRATEGY
    kernel: str = "matern52"
    budget: int = 50
    init: int = 10
    seed: int = 0
    mean: str = "constant"
    n_candidates: int = 10_000
    acquisition_restarts: int = 3
    gp_restarts: int = 2
    dense_refit: int = 40
    refit_every: int = 5
    pool_neighbourhood: float = 0.02
    #: Keep drawing uniform trials after ``init`` until one scores above the level (> 0).
    explore_until_success: bool = True
    #: ``lse2``: uniform controls per drawn context among which ψ picks (module doc).
    lse2_candidates: int = 100
    #: ``lse2``: when ψ ≤ 0 for every candidate of the drawn context (the GP classifies the
    #: whole slice at 95 %, so the straddle has no boundary there and ψ ranks by σ alone),
    #: take a uniform valid control instead of the largest ψ (module doc). ``False``: the
    #: choice before this fallback.
    lse2_uniform_if_classified: bool = True
    #: GP strategies: log-sd of the log-normal prior on the lengthscales (median
    #: ``DEFAULT_PRIOR.median``), fitted by MAP; ``None``: maximum marginal likelihood, the
    #: fit before issue #21 (see :class:`~ltamp_cli.learning.gp.LengthscalePrior`).
    lengthscale_prior_sd: float | None = DEFAULT_PRIOR.log_sd
    #: GP strategies: upper bound of every ARD lengthscale, normalised units (the input box
    #: is [-1, 1]); ``None``: ``HyperBounds().lengthscale``'s 20 ("irrelevant" allowed). The
    #: reference learner bounds its push lengthscales by 0.5 raw units (0.1-0.5 here, see
    #: ``gp_bounds``); ``docs/results/learning/README.md``, push section (issue #21).
    lengthscale_max: float | None = None
    #: ``lse``: 0 — the straddle chooses control and context; k > 0 — a context drawn from
    #: the skill's distribution is kept for k consecutive trials, the straddle choosing the
    #: control (:mod:`~ltamp_cli.learning.held_context`, issue #21). Online learning only
    #: (pool mode picks pool trials).
    context_repeats: int = 0
    #: Skills that declare an outcome (``SkillSpec.outcome``): add each trial's relabelled
    #: points (its achieved goal and ``hindsight_goals`` drawn goals, exact scores) to the
    #: training data, at most ``hindsight_cap`` of them (:mod:`~ltamp_cli.learning.outcomes`).
    #: ``False``, or a skill without an outcome: scores only, as before issue #21.
    hindsight: bool = True
    hindsight_goals: int = DEFAULT_GOALS_PER_TRIAL
    hindsight_cap: int = DEFAULT_CAP
    #: ``lse`` with relabelled trials: ``"outcome-cover"`` (default) — a GP on the trials'
    #: outcomes chooses the control expected to reach the most goals no trial has reached;
    #: ``lse2`` (among the drawn context's valid controls) and pool mode (among the pool
    #: candidates) rank by the same outcome acquisitions and fall back to the straddle only
    #: when no candidate has a positive value (:func:`_outcome_choice`); with ``"goal-mean"``
    #: or ``"joint"`` they use the plain straddle, their choice before issue #21's third
    #: outcome session (``docs/results/push/README.md``, "lse2 and pool mode");
    #: ``"outcome-var"`` / ``"outcome-sd"`` — the one whose outcome resolves the most goals'
    #: labels / is the least certain (:mod:`~ltamp_cli.learning.outcome_acquisition`);
    #: ``"goal-mean"`` — the control whose ψ averaged over drawn goals is largest
    #: (:func:`~ltamp_cli.learning.outcomes.propose_for_all_goals`, the default before the
    #: second outcome session: on the 2D push and flick2d it chose trials that did not move
    #: the object, ``docs/results/push/README.md``); ``"joint"`` — the plain straddle over
    #: control and context.
    hindsight_acquisition: str = "outcome-cover"
    #: ``lse2`` and pool mode with an outcome acquisition: the weight ``w`` of the
    #: candidate's own goal (the drawn goal; the pool trial's goal) in its value, the rest
    #: going to goals drawn over the box (:func:`~.outcome_acquisition.rank_by_outcome`).
    #: 0: the own goal does not count (what the outcome teaches does not depend on it).
    outcome_own_goal_weight: float = 0.0
    #: GP strategies with relabelled trials: θ* also considers the training controls
    #: (:attr:`~ltamp_cli.learning.model.LevelSetModel.data_candidates`).
    hindsight_theta_data: bool = True
    #: GP strategies with relabelled trials and no ``lengthscale_max``: this upper bound on
    #: every lengthscale (normalised units; ``None``: none). On the 2D push the relabelled
    #: data of a few pushes that moved the object let the marginal likelihood call the
    #: controls irrelevant (lengthscales at 20) and the goal-averaged straddle then chose
    #: pushes that never touched it; capped at 1.0 (half the box) the fit keeps the controls
    #: (``docs/results/learning/README.md``, "Outcomes").
    hindsight_lengthscale_max: float | None = 1.0
    threads: int | None = 1  # thread-pool limit while learning (ltamp_cli.threads)

    def __post_init__(self) -> None:
        if self.strategy not in STRATEGIES:
            raise ValueError(
                f"unknown strategy {self.strategy!r}: expected one of {', '.join(STRATEGIES)}"
            )
        if self.kernel not in KERNEL_NAMES:
            raise ValueError(
                f"unknown kernel {self.kernel!r}: expected one of {', '.join(KERNEL_NAMES)}"
            )
        if self.budget < 1 or self.init < 1:
            raise ValueError(f"budget and init must be >= 1, got {self.budget} and {self.init}")
        # any integer is a seed, as for `ltamp train --seed` (negative/huge ones are hashed)
        object.__setattr__(self, "seed", usable_seed(self.seed))
        if self.refit_every < 1:
            raise ValueError(f"refit_every must be >= 1, got {self.refit_every}")
        if self.lse2_candidates < 1:
            raise ValueError(f"lse2_candidates must be >= 1, got {self.lse2_candidates}")
        if self.context_repeats < 0:
            raise ValueError(f"context_repeats must be >= 0, got {self.context_repeats}")
        if self.hindsight_acquisition not in HINDSIGHT_ACQUISITIONS:
            raise ValueError(f"hindsight_acquisition must be one of "
                             f"{', '.join(HINDSIGHT_ACQUISITIONS)}, got "
                             f"{self.hindsight_acquisition!r}")
        if not 0.0 <= self.outcome_own_goal_weight <= 1.0:
            raise ValueError(f"outcome_own_goal_weight must be in [0, 1], got "
                             f"{self.outcome_own_goal_weight}")
        if self.hindsight_goals < 0 or self.hindsight_cap < 0:
            raise ValueError(f"hindsight_goals and hindsight_cap must be >= 0, got "
                             f"{self.hindsight_goals} and {self.hindsight_cap}")
        low, high = HyperBounds().lengthscale
        for name in ("lengthscale_max", "hindsight_lengthscale_max"):
            value = getattr(self, name)
            if value is not None and not low < value <= high:
                raise ValueError(f"{name} must be in ({low}, {high}], got {value}")
        if self.lengthscale_prior_sd is not None and not self.lengthscale_prior_sd > 0:
            raise ValueError(
                f"lengthscale_prior_sd must be > 0 or None, got {self.lengthscale_prior_sd}"
            )

    def relabeller(self, spec: SkillSpec) -> Relabeller | None:
        """The hindsight relabeller for ``spec`` (``None``: scores only)."""
        if not self.hindsight or spec.outcome is None:
            return None
        return Relabeller(spec, self.hindsight_goals, self.hindsight_cap, self.seed)

    def lengthscale_prior(self) -> LengthscalePrior | None:
        """The GP fit's lengthscale prior (``None``: maximum marginal likelihood)."""
        if self.lengthscale_prior_sd is None:
            return None
        return LengthscalePrior(DEFAULT_PRIOR.median, self.lengthscale_prior_sd)


@dataclass
class LearningResult:
    """The final model, every trial it was trained on, and the learning curve (if evaluated)."""

    model: SkillModel
    records: list[TrialRecord]
    curve: list[Evaluation] = field(default_factory=list)


def gp_bounds(spec: SkillSpec, lengthscale_max: float | None = None) -> HyperBounds:
    """The GP hyperparameter bounds for ``spec``: the defaults, with the noise variance capped
    at :data:`DETERMINISTIC_NOISE` when the skill's trials are deterministic and the
    lengthscales at ``lengthscale_max`` (normalised units) if given."""
    default = HyperBounds()
    noise = (default.noise[0], DETERMINISTIC_NOISE) if spec.deterministic else default.noise
    lengthscale = (default.lengthscale if lengthscale_max is None
                   else (default.lengthscale[0], lengthscale_max))
    return HyperBounds(lengthscale=lengthscale, noise=noise)


def fit_model(
    spec: SkillSpec,
    config: LearningConfig,
    x: np.ndarray,
    y: np.ndarray,
    previous: SkillModel | None = None,
    final: bool = False,
    rng: np.random.Generator | None = None,
    n_trials: int | None = None,
) -> SkillModel:
    """The strategy's model on normalised ``x (n, d)`` and scores ``y (n,)``.

    For GP strategies ``previous`` (the last model) gives the warm start; hyperparameters are
    re-optimised only when the refit schedule says so (always when ``final``). The schedule
    counts ``n_trials`` (default ``n``; less when ``x`` holds relabelled points too).
    """
    rng = rng if rng is not None else np.random.default_rng(config.seed)
    if config.strategy in GP_STRATEGIES:
        warm = previous.gp if isinstance(previous, LevelSetModel) else None
        n = len(y) if n_trials is None else n_trials
        relabelled = config.relabeller(spec) is not None
        data = config.hindsight_theta_data and relabelled
        cap = config.lengthscale_max
        if cap is None and relabelled:
            cap = config.hindsight_lengthscale_max
        if warm is not None and not final and n > config.dense_refit and n % config.refit_every:
            return LevelSetModel(spec, warm.with_data(x, y), data)
        restarts = config.gp_restarts if final or warm is None else 0
        gp = fit_gp(
            x, y, config.kernel, mean=config.mean, restarts=restarts, rng=rng, warm_start=warm,
            bounds=gp_bounds(spec, cap), prior=config.lengthscale_prior(),
        )
        return LevelSetModel(spec, gp, data)
    if config.strategy == "random":
        return RandomModel.fit(spec, x, y)
    return SklearnModel.fit(spec, config.strategy, x, y, seed=config.seed)


def uses_outcome_model(config: LearningConfig) -> bool:
    """Whether ``config``'s acquisition chooses trials with an :class:`OutcomeModel`."""
    return (config.strategy in ACTIVE_STRATEGIES and config.hindsight
            and config.hindsight_acquisition in OUTCOME_ACQUISITIONS)


def fit_outcome_model(
    spec: SkillSpec,
    config: LearningConfig,
    trials: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]],
    rng: np.random.Generator,
    previous: OutcomeModel | None = None,
) -> OutcomeModel | None:
    """The outcome GPs on ``trials`` (physical ``(context, control, outcome)`` each; ``None``
    when there are none), with the score GP's kernel, lengthscale cap and prior."""
    if not trials:
        return None
    cap = config.lengthscale_max if config.lengthscale_max is not None \
        else config.hindsight_lengthscale_max
    default = HyperBounds()
    bounds = HyperBounds(lengthscale=default.lengthscale if cap is None
                         else (default.lengthscale[0], cap), noise=default.noise)
    contexts, controls, outcomes = (np.array([t[i] for t in trials]) for i in range(3))
    return OutcomeModel.fit(spec, contexts, controls, outcomes, config.kernel, rng, previous,
                            bounds, config.lengthscale_prior())


def _trial_seed(seed: int, index: int) -> int:
    return int(np.random.SeedSequence([seed, index]).generate_state(1)[0] & 0x7FFFFFFF)


def _training_score(spec: SkillSpec, score: float) -> float:
    """A bare score's training value (non-finite: the skill's invalid score); records go
    through :func:`~ltamp_cli.trials.record.training_score`, which also knows validity."""
    return score if math.isfinite(score) else spec.invalid_score


def goes_active(config: LearningConfig, scores: Sequence[float],
                n_trials: int | None = None) -> bool:
    """Whether the next trial is chosen by the acquisition: an active strategy, past ``init``
    trials and (with ``explore_until_success``) at least one score above the level.
    ``n_trials``: the trials so far (default ``len(scores)``; pass it when ``scores`` holds
    relabelled points too, which count as successes but not as trials)."""
    n = len(scores) if n_trials is None else n_trials
    if config.strategy not in ACTIVE_STRATEGIES or n < config.init:
        return False
    return not config.explore_until_success or any(s > 0 for s in scores)


def _checkpoint(n: int, config: LearningConfig, eval_every: int) -> bool:
    return n == config.budget or (eval_every > 0 and n >= config.init and n % eval_every == 0)


class _Learner:
    """Training data so far and the model on it, refitted lazily (eagerly for active ones)."""

    def __init__(self, spec: SkillSpec, config: LearningConfig, rng: np.random.Generator) -> None:
        self.spec = spec
        self.config = config
        self.rng = rng
        self.x: list[np.ndarray] = []
        self.y: list[float] = []
        self.model: SkillModel | None = None
        self._fitted_on = -1
        self.relabeller = config.relabeller(spec)
        self._outcome: OutcomeModel | None = None

    def add(self, x: np.ndarray, record: TrialRecord) -> None:
        """One trial: its normalised inputs ``x (d,)`` and its record, labelled by
        :func:`~ltamp_cli.trials.record.training_score` (an invalid trial is never a
        success). A valid record's outcome feeds the relabeller when the skill declares one
        (an invalid trial's "outcome" was never observed to its end)."""
        self.x.append(np.asarray(x, dtype=float))
        self.y.append(training_score(record, self.spec.invalid_score))
        if (self.relabeller is not None and record.valid and record.outcome is not None
                and math.isfinite(record.score)):
            self.relabeller.add(np.asarray(record.context), np.asarray(record.control),
                                np.asarray(record.outcome))

    def training_set(self) -> tuple[np.ndarray, np.ndarray]:
        """The model's data: the trials ``(n, d)``, ``(n,)`` plus kept relabelled points."""
        x, y = np.array(self.x), np.array(self.y)
        if self.relabeller is None:
            return x, y
        extra_x, extra_y = self.relabeller.arrays()
        x = x.reshape(len(y), extra_x.shape[1])
        return np.concatenate([x, extra_x]), np.concatenate([y, extra_y])

    def scores(self) -> Sequence[float]:
        """Every training score, relabelled ones included (what ``goes_active`` looks at)."""
        return self.y if self.relabeller is None else self.training_set()[1].tolist()

    def current(self) -> SkillModel:
        if self.model is None or self._fitted_on != len(self.y):
            x, y = self.training_set()
            self.model = fit_model(self.spec, self.config, x, y, self.model, rng=self.rng,
                                   n_trials=len(self.y))
            self._fitted_on = len(self.y)
        return self.model

    def outcome_model(self) -> OutcomeModel | None:
        """The outcome GPs on the trials so far, when the acquisition uses them."""
        if self.relabeller is None or not uses_outcome_model(self.config):
            return None
        self._outcome = fit_outcome_model(self.spec, self.config, self.relabeller.trials,
                                          self.rng, self._outcome)
        return self._outcome

    def final(self) -> SkillModel:
        x, y = self.training_set()
        return fit_model(self.spec, self.config, x, y, self.model, final=True, rng=self.rng,
                         n_trials=len(self.y))


def learner_from_records(spec: SkillSpec, config: LearningConfig,
                         records: Sequence[TrialRecord],
                         rng: np.random.Generator) -> _Learner:
    """The learner of ``records`` (in their order) exactly as a training run builds it: the
    trials' normalised inputs and scores, plus their relabelled points when ``spec`` declares
    an outcome and ``config.hindsight`` is on (records without an outcome add their score
    only). ``ltamp train --refit``, the ask/tell API and a resumed run all fit this one."""
    learner = _Learner(spec, config, rng)
    template = RandomModel(spec, 0.0)  # coordinates only
    for record in records:
        learner.add(template.to_unit(record.context, record.control)[0], record)
    return learner


def training_metadata(spec: SkillSpec, config: LearningConfig) -> dict[str, object]:
    """What a saved model records of its relabelling (``model.json``'s
    ``training.hindsight``): ``None`` when its data are the trials' scores only."""
    if config.relabeller(spec) is None:
        return {"hindsight": None}
    # "acquisition_in": where the acquisition chooses trials (models saved before it was
    # recorded chose by the straddle in lse2 and pool mode whatever "acquisition" says).
    return {"hindsight": {"goals": config.hindsight_goals, "cap": config.hindsight_cap,
                          "acquisition": config.hindsight_acquisition,
                          "acquisition_in": ["lse", "lse2", "pool"],
                          "own_goal_weight": config.outcome_own_goal_weight,
                          "theta_data": config.hindsight_theta_data}}


class _Curve:
    def __init__(self, evaluator: SkillEvaluator | None, eval_every: int, success: bool) -> None:
        self.evaluator = evaluator
        self.eval_every = eval_every
        self.success = success
        self.points: list[Evaluation] = []

    def maybe(self, learner: _Learner) -> None:
        n = len(learner.y)
        if self.evaluator is not None and _checkpoint(n, learner.config, self.eval_every):
            self.points.append(self.evaluator.evaluate(learner.current(), n, self.success))


@limits_threads
def learn_online(
    backend: SkillBackend,
    skill: str,
    config: LearningConfig,
    dataset: TrialDataset | None = None,
    evaluator: SkillEvaluator | None = None,
    eval_every: int = 0,
    progress: bool = False,
    evaluate_success: bool = True,
) -> LearningResult:
    """Run up to ``config.budget`` live trials of ``skill`` and return the trained model.

    Trials already in ``dataset`` (same skill) count toward the budget: a rerun resumes.
    ``evaluator`` with ``eval_every > 0`` records a learning curve every ``eval_every`` trials.
    Thread pools are limited to ``config.threads`` meanwhile, as in ``ltamp train``.
    ``dataset``'s writer lock is held throughout (:func:`~ltamp_cli.writer_lock.exclusive_writer`),
    as ``ltamp train`` holds its model directory's: a second writer of the same file (another
    thread or process) gets an :class:`~ltamp_cli.errors.InputError` instead of appending
    the same trials again.
    """
    if dataset is None:
        return _learn_online(backend, skill, config, None, evaluator, eval_every, progress,
                             evaluate_success)
    with exclusive_writer(dataset.path, is_directory=False, option="dataset"):
        return _learn_online(backend, skill, config, dataset, evaluator, eval_every,
                             progress, evaluate_success)


def refuse_pending_trial(dataset: TrialDataset) -> None:
    """Refuse to append live trials to the ``trials.jsonl`` of an ask/tell directory whose
    proposal is still pending: they would take the proposal's index, and its told result
    could no longer be recorded under it (:func:`~.ask_tell.tell`)."""
    from ltamp_cli.learning.ask_tell import PENDING_FILE, TRIALS_FILE

    pending = dataset.path.parent / PENDING_FILE
    if dataset.path.name == TRIALS_FILE and pending.is_file():
        raise InputError(
            "a trial proposed by `ltamp train --ask` is pending here: tell its outcome first "
            "(`ltamp tell DIR --score S`), or delete pending.json to drop it",
            location_in(pending))


def check_same_trials(records: Sequence[TrialRecord], backend: SkillBackend, skill: str,
                      where: str) -> None:
    """Refuse ``records`` (a run's own trials, read from ``where``) that ``backend``'s
    ``skill`` trials must not join: another skill or robot (``ValueError``), another version
    of the backend's trial setup (``ValueError``) or another physics (:class:`InputError`).
    Live learning (:func:`learn_online`) and ``ask`` (trials run outside ltamp, labelled for
    this backend) resume only on these terms."""
    strangers = [r for r in records if r.skill != skill]
    if strangers:
        raise ValueError(f"{where} holds trials of skill {strangers[0].skill!r}, not {skill!r}")
    # Labels of a robot-in-the-loop trial and of a free-floating one differ: never mix them.
    other = next((r.backend for r in records
                  if r.backend != backend.name and "+" in f"{r.backend}{backend.name}"), None)
    if other is not None:
        raise ValueError(
            f"{where} holds {other} trials, not {backend.name} ones; use another --out"
        )
    setup = trial_setup(backend, skill)
    stranger = next((r for r in records if r.backend == backend.name and r.setup != setup), None)
    if stranger is not None:  # the same backend, another version of its setup: other labels
        raise ValueError(
            f"{where} holds {backend.name} trials of {setup_words(stranger.setup)}, not "
            f"{setup_words(setup)}; use another --out"
        )
    # Nor labels of another physics (e.g. the scoop's 5 vs 50 solver iterations).
    check_physics(records, backend_physics(backend, skill), where, "use another --out")


def _learn_online(
    backend: SkillBackend,
    skill: str,
    config: LearningConfig,
    dataset: TrialDataset | None,
    evaluator: SkillEvaluator | None,
    eval_every: int,
    progress: bool,
    evaluate_success: bool,
) -> LearningResult:
    """:func:`learn_online` holding the dataset's writer lock."""
    spec = skill_spec(backend, skill)  # KeyError naming the backend's skills
    if dataset is not None:
        refuse_pending_trial(dataset)
    records = dataset.read() if dataset is not None and dataset.exists() else []
    check_same_trials(records, backend, skill, str(dataset.path) if dataset else "the trials")
    setup, physics = trial_setup(backend, skill), backend_physics(backend, skill)
    indices = [r.index for r in records if r.index >= 0]
    if len(set(indices)) != len(indices):
        repeated = next(i for i in indices if indices.count(i) > 1)
        raise ValueError(f"{dataset.path if dataset else ''}: trial {repeated} is recorded "
                         "twice (two writers shared it); keep one copy of each trial")
    rng = np.random.default_rng([config.seed, len(records)])
    learner = learner_from_records(spec, config, records, rng)
    template = RandomModel(spec, 0.0)  # coordinates and validity only
    curve = _Curve(evaluator, eval_every, evaluate_success)

    def is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return backend.is_valid(skill, context, controls)

    bar = tqdm(
        total=config.budget,
        initial=min(len(records), config.budget),
        disable=not progress,
        file=sys.stderr,
        desc=f"{config.strategy} {skill}",
        unit="trial",
    )
    held = (HeldContext(spec, config.context_repeats,
                        lambda r: drawn_context(backend, skill, r))
            if config.strategy == "lse" and config.context_repeats > 0 else None)
    with bar:
        while len(records) < config.budget:
            model = (learner.current() if goes_active(config, learner.scores(), len(learner.y))
                     else None)
            if held is not None and isinstance(model, LevelSetModel):
                context, control = held.propose(model, rng, is_valid, config.n_candidates,
                                                config.acquisition_restarts)
            else:
                outcome_model = (learner.outcome_model() if isinstance(model, LevelSetModel)
                                 else None)
                context, control = _propose(backend, skill, spec, config, rng, model, is_valid,
                                            outcome_model)
            index = len(records)
            seed = _trial_seed(config.seed, index)
            start = time.perf_counter()
            # A raising or diverged trial is recorded invalid: re-raising would crash every
            # resume too, as the resumed run proposes the same trial again.
            result, _crashed = run_trial_safely(backend, skill, context, control, seed)
            record = TrialRecord(
                skill=skill,
                context=tuple(float(v) for v in context),
                control=tuple(float(v) for v in control),
                score=float(result.score),
                valid=bool(result.valid),
                seed=seed,
                backend=backend.name,
                wall_time_s=time.perf_counter() - start,
                index=index,
                info={"strategy": config.strategy, **dict(result.info)},
                outcome=None if result.outcome is None else tuple(result.outcome),
                setup=setup,
                physics=physics,
            )
            if dataset is not None:
                dataset.append(record)
            records.append(record)
            learner.add(template.to_unit(context, control)[0], record)
            curve.maybe(learner)
            bar.update(1)
    return LearningResult(learner.final(), records, curve.points)


def _propose(
    backend: SkillBackend,
    skill: str,
    spec: SkillSpec,
    config: LearningConfig,
    rng: np.random.Generator,
    model: SkillModel | None,
    is_valid: PhysicalValidity,
    outcome_model: OutcomeModel | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Next ``(context (dα,), control (dθ,))`` in physical units; random without a GP.
    ``outcome_model``: the outcome GPs, for the outcome acquisitions."""
    if not isinstance(model, LevelSetModel):
        context = drawn_context(backend, skill, rng)
        return context, spec.control.sample_uniform(rng, 1)[0]
    test = model.validity_test(is_valid)
    if config.strategy == "lse" and outcome_model is not None and uses_outcome_model(config):
        x = propose_by_outcome(spec, outcome_model, rng, config.n_candidates, test,
                               config.hindsight_acquisition)
        if x is not None:
            contexts, controls = model.from_unit(x[None, :])
            return contexts[0], controls[0]
    if (config.strategy == "lse" and config.hindsight_acquisition == "goal-mean"
            and config.relabeller(spec) is not None):
        chosen = propose_for_all_goals(model, rng, config.n_candidates, test)
        if chosen is not None:
            return chosen
    if config.strategy == "lse":
        best = maximize(
            model.gp,
            straddle,
            rng,
            n_candidates=config.n_candidates,
            n_restarts=config.acquisition_restarts,
            is_valid=test,
        )
        if best is not None:
            contexts, controls = model.from_unit(best.x)
            return contexts[0], controls[0]
        context = drawn_context(backend, skill, rng)
    else:
        context = drawn_context(backend, skill, rng)
        control = _lse2_control(model, spec, config, context, rng, is_valid, outcome_model)
        if control is not None:
            return context, control
    return context, spec.control.sample_uniform(rng, 1)[0]


def _lse2_control(
    model: LevelSetModel,
    spec: SkillSpec,
    config: LearningConfig,
    context: np.ndarray,
    rng: np.random.Generator,
    is_valid: PhysicalValidity,
    outcome_model: OutcomeModel | None = None,
) -> np.ndarray | None:
    """The control ``(dθ,)`` with the largest ψ for physical ``context (dα,)`` among
    ``config.lse2_candidates`` uniform ones that pass the pre-check (a uniform one of them if
    ψ ≤ 0 for all and ``config.lse2_uniform_if_classified``); ``None`` if none passes.
    With ``outcome_model`` (a skill with an outcome, :func:`uses_outcome_model`): the
    candidate of largest outcome value (:func:`_outcome_choice`), ψ only if none has one."""
    controls = spec.control.sample_uniform(rng, config.lse2_candidates)
    controls = controls[np.asarray(is_valid(context, controls), dtype=bool)]
    if len(controls) == 0:
        return None
    contexts = np.repeat(np.asarray(context, dtype=float).reshape(1, -1), len(controls), axis=0)
    if outcome_model is not None and uses_outcome_model(config):
        pick = _outcome_choice(spec, config, outcome_model, model.to_unit(contexts, controls),
                               rng)
        if pick is not None:
            return controls[pick]
    values = evaluate(model.gp, straddle, model.to_unit(contexts, controls))
    best = int(np.argmax(values))
    if config.lse2_uniform_if_classified and not values[best] > 0:
        # No candidate is unclassified: the straddle has nothing to refine in this slice and
        # its argmax is the largest σ, i.e. the candidate farthest from the data (module doc).
        # The candidates are uniform and valid, so the first one is a uniform valid control.
        return controls[0]
    return controls[best]


@limits_threads
def learn_from_pool(
    spec: SkillSpec,
    pool: Sequence[TrialRecord],
    config: LearningConfig,
    evaluator: SkillEvaluator | None = None,
    eval_every: int = 0,
    progress: bool = False,
    evaluate_success: bool = True,
    final_fit: bool = True,
    kind: TrialKind | None = None,
) -> LearningResult:
    """Learn from pre-collected trials, choosing each next one from the pool without replacement.

    The pool's trials of the skill must be of one :class:`~ltamp_cli.trials.physics.TrialKind`
    (backend, robot setup, physics; ``kind`` when given, e.g. the backend's the model is
    for, else the first trial's): another is an :class:`~ltamp_cli.errors.InputError` naming
    the pool record and both values (imported real-world trials are exempt).

    Active strategies pick the remaining trial with the largest straddle ψ (``lse``: over the
    whole pool; ``lse2``: among the ``pool_neighbourhood`` fraction of remaining trials whose
    contexts are nearest to that of a uniformly drawn remaining trial); the others take the
    pool in a random order. At most ``min(budget, len(pool))`` trials are used. Thread pools
    are limited to ``config.threads`` meanwhile, as in ``ltamp train``. ``final_fit=False``
    skips the final full refit (random restarts) for callers that only want the curve: the
    result's model is then the last one fitted (refitted on all trials only if no checkpoint
    fell on the last trial); the curve is the same either way (the final fit comes after it).
    """
    # Numbered in the pool as given (before, among its trials of this skill only, so a pool
    # of several skills had the wrong record named).
    numbered = [(i, r) for i, r in enumerate(pool) if r.skill == spec.name]
    pool = [r for _i, r in numbered]
    if not pool:
        raise ValueError(f"the pool has no trials of skill {spec.name!r}")
    check_trial_kind(((f"pool record {i}", r) for i, r in numbered), kind,
                     "the expected kind" if kind is not None else "",
                     "learn from trials of one kind")
    # as `ltamp train --data` reads its file: a trial repeated (two writers once shared the
    # file) is used once, else it would be chosen, and weigh, twice
    pool, repeats = without_duplicates(pool)
    if repeats:
        logging.getLogger("ltamp").warning(
            "the pool repeats %d trial record(s) with the same (seed, index); each trial is "
            "used once", repeats)
    check_against_spec(pool, spec)  # wrong lengths, far-off values: one ValueError
    rng = np.random.default_rng(config.seed)
    template = RandomModel(spec, 0.0)
    x_pool = np.array([template.to_unit(r.context, r.control)[0] for r in pool]).reshape(
        len(pool), -1
    )
    budget = min(config.budget, len(pool))
    order = rng.permutation(len(pool))
    available = np.ones(len(pool), dtype=bool)
    chosen: list[int] = []
    learner = _Learner(spec, config, rng)
    curve = _Curve(evaluator, eval_every, evaluate_success)
    cursor = 0
    bar = tqdm(
        total=budget,
        disable=not progress,
        file=sys.stderr,
        desc=f"{config.strategy} {spec.name} (pool)",
        unit="trial",
    )
    with bar:
        while len(chosen) < budget:
            model = (learner.current() if goes_active(config, learner.scores(), len(learner.y))
                     else None)
            if isinstance(model, LevelSetModel):
                index = _pool_pick(model, config, spec, x_pool, available, rng,
                                   learner.outcome_model())
            else:
                while not available[order[cursor]]:
                    cursor += 1
                index = int(order[cursor])
            available[index] = False
            chosen.append(index)
            learner.add(x_pool[index], pool[index])
            curve.maybe(learner)
            bar.update(1)
    model = learner.final() if final_fit else learner.current()
    return LearningResult(model, [pool[i] for i in chosen], curve.points)


def _pool_pick(
    model: LevelSetModel,
    config: LearningConfig,
    spec: SkillSpec,
    x_pool: np.ndarray,
    available: np.ndarray,
    rng: np.random.Generator,
    outcome_model: OutcomeModel | None = None,
) -> int:
    """The pool index of the next trial (``learn_from_pool``'s doc); with ``outcome_model``
    the candidate of largest outcome value (:func:`_outcome_choice`; for ``lse`` among at
    most ``n_candidates // DEFAULT_GOALS`` remaining trials drawn at random, as many as
    online ``lse`` scores), the straddle only if none has one."""
    remaining = np.flatnonzero(available)
    if config.strategy == "lse2" and spec.context.dim > 0:
        anchor = x_pool[rng.choice(remaining), spec.control.dim :]
        distance = np.linalg.norm(x_pool[remaining, spec.control.dim :] - anchor, axis=1)
        size = max(1, min(len(remaining), math.ceil(config.pool_neighbourhood * len(x_pool))))
        remaining = remaining[np.argsort(distance, kind="stable")[:size]]
    if outcome_model is not None and uses_outcome_model(config):
        ranked = remaining
        limit = max(1, config.n_candidates // DEFAULT_GOALS)
        if len(ranked) > limit:
            ranked = np.sort(rng.choice(ranked, size=limit, replace=False))
        pick = _outcome_choice(spec, config, outcome_model, x_pool[ranked], rng)
        if pick is not None:
            return int(ranked[pick])
    values = evaluate(model.gp, straddle, x_pool[remaining])
    return int(remaining[int(np.argmax(values))])


def _outcome_choice(spec: SkillSpec, config: LearningConfig, outcome_model: OutcomeModel,
                    candidates: np.ndarray, rng: np.random.Generator) -> int | None:
    """Index of the candidate (normalised joint inputs ``(m, d)``, each with its own goal)
    of largest value under ``config.hindsight_acquisition``
    (:func:`~.outcome_acquisition.rank_by_outcome`, own-goal weight
    ``config.outcome_own_goal_weight``); ``None`` when no value is positive (e.g. every goal
    reached already, or no candidate expected to reach a new one): the caller's straddle
    then breaks the tie."""
    values = rank_by_outcome(spec, outcome_model, candidates, rng, config.hindsight_acquisition,
                             config.outcome_own_goal_weight)
    best = int(np.argmax(values))
    return best if values[best] > 0 else None
