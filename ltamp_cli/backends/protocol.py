"""The backend protocol: the one small interface every physics backend implements.

A *backend* (Box2D Kitchen2D, PyBullet Kitchen3D, SAPIEN, or the analytic ``synthetic``
backend) exposes a set of parameterised skills and runs trials of them. Learning and data
collection only ever talk to backends through :class:`SkillBackend`, in the spirit of
Gymnasium's ``Env``: everything else a backend does is its own business.

Conventions
-----------
* Parameters are given in *physical units* (what :class:`ParamSpace` bounds describe);
  learners normalise to ``[-1, 1]`` themselves.
* ``context`` has shape ``(d_context,)`` and ``control`` has shape ``(d_control,)``.
* A trial is deterministic given ``(context, control, seed)``.
* ``score > 0`` means the skill succeeded (the super-level set ``g > 0`` is what is learned).
* An *invalid* control (e.g. a colliding start) is not simulated: it gets ``valid=False``
  and the skill's invalid score (usually ``-1``).

Outcomes (optional, issue #21)
------------------------------
A skill may declare an :class:`OutcomeSpec` (``SkillSpec.outcome``): a named vector in
physical units that each valid trial reports beside its score (``TrialResult.outcome``, shape
``(d_outcome,)``; e.g. the pushed object's end position), the vectorised function giving the
score from ``(context, control, outcome)``, and which context dimensions are *goals*: the
physics does not depend on them, only the score does. Then one trial's outcome scores the
same control for *every* goal exactly, and learners use that
(:mod:`ltamp_cli.learning.outcomes`: hindsight relabelling). A skill that declares none
(``outcome=None``, the default) is learned from its scores alone, exactly as before. A valid
trial of a skill with an outcome must report one of the declared length with finite values,
and the declared score function must reproduce the trial's score from it; otherwise the trial
is recorded invalid with the reason (:func:`ltamp_cli.backends.sanity.run_trial_safely`).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np


@dataclass(frozen=True)
class ParamSpace:
    """Named box-bounded real parameters. ``lows``/``highs`` are in physical units;
    ``units`` (optional, one per name, ``""`` for a pure number) names them for plots."""

    names: tuple[str, ...]
    lows: tuple[float, ...]
    highs: tuple[float, ...]
    units: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not (len(self.names) == len(self.lows) == len(self.highs)):
            raise ValueError("names, lows and highs must have the same length")
        if any(lo > hi for lo, hi in zip(self.lows, self.highs, strict=True)):
            raise ValueError("every low must be <= its high")
        if self.units and len(self.units) != len(self.names):
            raise ValueError("units must be empty or one per name")

    def unit(self, index: int) -> str:
        """The unit of parameter ``index`` (``""`` when none was given)."""
        return self.units[index] if self.units else ""

    def label(self, index: int) -> str:
        """``"name [unit]"`` (or ``"name"`` without a unit), for axis labels."""
        unit = self.unit(index)
        return f"{self.names[index]} [{unit}]" if unit else self.names[index]

    @property
    def dim(self) -> int:
        return len(self.names)

    def low_array(self) -> np.ndarray:
        return np.asarray(self.lows, dtype=float)

    def high_array(self) -> np.ndarray:
        return np.asarray(self.highs, dtype=float)

    def sample_uniform(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` uniform points in the box, shape ``(n, dim)``."""
        return rng.uniform(self.low_array(), self.high_array(), size=(n, self.dim))


#: ``(contexts (n, d_context), controls (n, d_control), outcomes (n, d_outcome)) -> scores
#: (n,)``, all in physical units: a skill's score as a function of what its trial observed.
OutcomeScore = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
#: ``outcomes (n, d_outcome) -> goals (n, len(goals))``: the goal values each outcome
#: satisfies best (e.g. the object's end position for a push to a goal position).
AchievedGoal = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class OutcomeSpec:
    """What a skill's trials observe besides the score (module doc, "Outcomes").

    ``space`` names the outcome's values and their units; its bounds are the plausible range
    (a reported value more than one box width beyond a bound makes the trial invalid, as for
    records). ``score`` computes the score from ``(context, control, outcome)`` batches;
    ``goals`` lists the context dimensions (indices into the skill's context) that are goals:
    the trial's physics, hence its outcome, must not depend on them. ``achieved_goal``
    (optional) maps an outcome to the goal it satisfies best; learners then add that goal
    to their relabelled data (:mod:`ltamp_cli.learning.outcomes`).
    """

    space: ParamSpace
    score: OutcomeScore
    goals: tuple[int, ...]
    achieved_goal: AchievedGoal | None = None

    def __post_init__(self) -> None:
        if self.space.dim < 1:
            raise ValueError("an outcome needs at least one value")
        for name, low, high in zip(self.space.names, self.space.lows, self.space.highs,
                                   strict=True):
            # as SkillSpec's context and control: a NaN bound would make every outcome
            # "far outside its declared range", hence every trial invalid
            numbers_ok = all(isinstance(v, int | float | np.number) and not isinstance(v, bool)
                             for v in (low, high))
            if not (numbers_ok and math.isfinite(low) and math.isfinite(high)
                    and math.isfinite(high - low) and low <= high):
                raise ValueError(f"outcome {name!r:.40} has bounds [{low}, {high}]: expected "
                                 "finite numbers low <= high with a finite width")
        if any(isinstance(g, bool | np.bool_) or not isinstance(g, numbers.Integral)
               for g in self.goals):
            raise ValueError(f"outcome goals must be integer context indices, got {self.goals}")
        object.__setattr__(self, "goals", tuple(int(g) for g in self.goals))  # np.int64 too
        if not self.goals or len(set(self.goals)) != len(self.goals):
            raise ValueError(f"outcome goals must be distinct context indices, got {self.goals}")
        if any(g < 0 for g in self.goals):
            raise ValueError(f"outcome goals must be context indices >= 0, got {self.goals}")

    def scores(self, contexts: np.ndarray, controls: np.ndarray,
               outcomes: np.ndarray) -> np.ndarray:
        """The declared score for a batch, shape ``(n,)``; ``ValueError`` if the skill's
        function returns another shape or non-finite values."""
        contexts, controls = np.atleast_2d(contexts), np.atleast_2d(controls)
        outcomes = np.asarray(outcomes, dtype=float).reshape(len(contexts), self.space.dim)
        values = np.asarray(self.score(contexts, controls, outcomes), dtype=float)
        if values.shape != (len(contexts),):
            raise ValueError(f"the outcome score function returned shape {values.shape}, "
                             f"expected ({len(contexts)},)")
        if not np.isfinite(values).all():
            raise ValueError("the outcome score function returned non-finite scores")
        return values

    def check(self, outcome: object) -> tuple[float, ...]:
        """One reported outcome as a tuple of ``space.dim`` finite floats within one box width
        of the bounds, or ``ValueError`` saying what is wrong (one line)."""
        try:
            values = np.asarray(outcome, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"outcome {outcome!r:.60} is not a list of numbers") from None
        if values.shape != (self.space.dim,):
            raise ValueError(f"outcome has shape {values.shape}, the skill declares "
                             f"{self.space.dim} value(s) ({', '.join(self.space.names)})")
        if not np.isfinite(values).all():
            raise ValueError(f"outcome {values.tolist()} has non-finite values")
        for name, value, low, high in zip(self.space.names, values, self.space.lows,
                                          self.space.highs, strict=True):
            width = max(high - low, 1e-9)
            if not low - width <= value <= high + width:
                raise ValueError(f"outcome {name}={value:g} lies far outside its declared "
                                 f"range [{low:g}, {high:g}]")
        return tuple(float(v) for v in values)


@dataclass(frozen=True)
class SkillSpec:
    """What a skill is: its context and control parameters and how it is scored."""

    name: str
    context: ParamSpace
    control: ParamSpace
    description: str = ""
    invalid_score: float = -1.0
    #: True when a trial's score is a deterministic function of (context, control) (the
    #: seed changes nothing): a GP fitted to it is given almost no observation noise
    #: (:data:`ltamp_cli.learning.active.DETERMINISTIC_NOISE`), so its marginal likelihood
    #: cannot explain a narrow success set away as noise.
    deterministic: bool = False
    #: What a trial observes besides its score, and how the score follows from it (module
    #: doc, "Outcomes"); ``None``: the skill reports scores only.
    outcome: OutcomeSpec | None = None

    def __post_init__(self) -> None:
        # What a saved model must hold (model_dir.checked_spec): a skill that breaks it would
        # be trained for nothing, its model refused on load ("the name 'a' is used twice").
        seen: set[str] = set()
        for part, space in (("context", self.context), ("control", self.control)):
            for name, low, high in zip(space.names, space.lows, space.highs, strict=True):
                if not isinstance(name, str) or not name.strip():
                    raise ValueError(f"skill {self.name!r}: {part} names must be non-empty "
                                     f"strings, not {name!r:.40}")
                if name in seen:  # --context name=value, model inputs: must be unambiguous
                    raise ValueError(f"skill {self.name!r}: the name {name!r:.40} is used "
                                     "twice (context and control names must be distinct)")
                seen.add(name)
                numbers = all(isinstance(v, int | float | np.number) and not isinstance(v, bool)
                              for v in (low, high))
                if not (numbers and math.isfinite(low) and math.isfinite(high)
                        and math.isfinite(high - low)):
                    raise ValueError(f"skill {self.name!r}: {part} {name!r:.40} has bounds "
                                     f"[{low}, {high}]: expected finite numbers with a "
                                     "finite width")
        score = self.invalid_score
        if (isinstance(score, bool) or not isinstance(score, int | float | np.number)
                or not math.isfinite(score) or score > 0):
            # an invalid trial never succeeds (score > 0 is success), and a NaN/inf label
            # would poison every GP fitted to the skill's trials
            raise ValueError(f"skill {self.name!r}: invalid_score must be a finite number "
                             f"<= 0, not {score!r:.40}")
        if self.outcome is not None and max(self.outcome.goals) >= self.context.dim:
            raise ValueError(f"skill {self.name!r}: outcome goal index "
                             f"{max(self.outcome.goals)} is not a context dimension "
                             f"(the context has {self.context.dim})")


@dataclass(frozen=True)
class TrialResult:
    """What one trial gave. ``info`` holds skill-specific measurements (JSON-able);
    ``outcome`` the declared outcome ``(d_outcome,)`` in physical units when the skill
    declares one (``SkillSpec.outcome``) and the trial was simulated, else ``None``."""

    score: float
    valid: bool
    info: Mapping[str, Any] = field(default_factory=dict)
    outcome: Sequence[float] | None = None


@runtime_checkable
class SkillBackend(Protocol):
    """What every backend provides to learning and data collection."""

    name: str

    def skills(self) -> Mapping[str, SkillSpec]:
        """All skills this backend can run, by name."""
        ...

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        """Draw one context from the skill's context distribution, shape ``(d_context,)``."""
        ...

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        """Cheap hard validity test (no simulation) for a batch.

        ``controls`` has shape ``(n, d_control)``; returns a bool array of shape ``(n,)``.
        """
        ...

    def run_trial(
        self, skill: str, context: np.ndarray, control: np.ndarray, seed: int
    ) -> TrialResult:
        """Run (simulate) one trial of ``skill``; deterministic given ``seed``."""
        ...

    def close(self) -> None:
        """Release physics resources. Backends reuse their world across trials until then."""
        ...


def trial_setup(backend: SkillBackend, skill: str) -> str | None:
    """The versioned setup of ``backend``'s ``skill`` trials, which their records carry
    (:attr:`~ltamp_cli.trials.record.TrialRecord.setup`), or ``None`` (the backend has none).

    Optional part of the protocol: a backend whose trials depend on a setup that changes
    between releases without changing its name (PyBullet with the Panda: grasps, base
    placement, timing, ``ROBOT_SETUP_VERSIONS``) defines ``trial_setup(skill) -> str | None``.
    A plugin's answer that is neither ``None`` nor a non-empty string is one
    :class:`~ltamp_cli.errors.InputError` line naming the backend.
    """
    return optional_version(backend, "trial_setup", skill)


def optional_version(backend: Any, method_name: str, skill: str) -> str | None:
    """Ask ``backend``'s optional per-skill version hook ``method_name(skill)`` (``trial_setup``,
    ``physics_tag``): ``None`` if the backend has no such method or answers ``None``.

    A record stores the answer verbatim, so anything but ``None`` or a non-empty string (a
    ``str()`` of it would be written into every record and refuse the plugin's own older
    files), or an exception other than ``KeyError`` (an unknown skill, as
    :func:`skill_spec` reports it), is one :class:`~ltamp_cli.errors.InputError` line naming
    the backend, not a traceback.
    """
    from ltamp_cli.errors import InputError

    method = getattr(backend, method_name, None)
    if method is None:
        return None
    where = f"backend {getattr(backend, 'name', '?')!r} ({type(backend).__module__})"
    try:
        answer = method(skill)
    except KeyError:
        raise
    except Exception as error:  # a plugin's bug
        raise InputError(f"{where}: {method_name}({skill!r}) raised "
                         f"{type(error).__name__}: {error}") from None
    if answer is None or (isinstance(answer, str) and answer.strip()):
        return answer
    raise InputError(f"{where}: {method_name}({skill!r}) returned {answer!r:.40}: expected "
                     "None or a non-empty string")


def skill_spec(backend: SkillBackend, skill: str) -> SkillSpec:
    """Look a skill up by name, or raise ``KeyError`` naming the known ones."""
    specs = backend.skills()
    if skill not in specs:
        known = ", ".join(sorted(specs))
        raise KeyError(f"backend {backend.name!r} has no skill {skill!r} (known: {known})")
    return specs[skill]


def drawn_context(backend: SkillBackend, skill: str, rng: np.random.Generator) -> np.ndarray:
    """``backend.sample_context(skill, rng)`` as a ``(dα,)`` float array, checked: a context
    that is not ``dα`` finite numbers inside the skill's context box is a bug of the backend
    (a plugin's, usually), reported as one :class:`~ltamp_cli.errors.InputError` line naming
    the backend, its module and what was expected, not a numpy error deep in learning."""
    from ltamp_cli.errors import InputError

    space = skill_spec(backend, skill).context
    drawn = backend.sample_context(skill, rng)
    where = (f"backend {getattr(backend, 'name', '?')!r} ({type(backend).__module__}): "
             f"sample_context({skill!r}) returned {drawn!r:.80}")
    expected = (f"expected {space.dim} finite number(s) ({', '.join(space.names) or 'none'}) "
                f"inside the skill's context bounds")
    try:
        values = np.asarray(drawn, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"{where}: {expected}") from None
    if values.size != space.dim or not np.all(np.isfinite(values)):
        raise InputError(f"{where}: {expected}")
    lows, highs = space.low_array(), space.high_array()
    slack = 1e-12 * (highs - lows)
    if np.any(values < lows - slack) or np.any(values > highs + slack):
        box = ", ".join(f"{lo:g}..{hi:g}" for lo, hi in zip(lows, highs, strict=True))
        raise InputError(f"{where}: {expected} [{box}]")
    return values


def as_batch(controls: Sequence[float] | np.ndarray, dim: int) -> np.ndarray:
    """View one control or a batch of controls as an array of shape ``(n, dim)``."""
    array = np.asarray(controls, dtype=float)
    return array.reshape(-1, dim)
