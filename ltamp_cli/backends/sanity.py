"""Divergence guard shared by the physics backends' trial runners.

A simulation that blows up (a non-finite state, a body thrown out of any sensible workspace or
moving absurdly fast) must not crash a collection or hand a meaningless score to a learner:
the trial is invalid, with the skill's invalid score and the reason in ``info["reason"]``.
Each backend says how to list its moving bodies and read one body's state, and calls
:meth:`BodyGuard.step` after every simulation step: each step checks a rotating ``1/every``
slice of the bodies, so every body is checked every ``every`` steps for the cost of one full
check (checking all of them every step would cost as much as the physics for hundreds of
particles), yet a NaN, which reaches every touching body within a step, is caught at the next
step (a physics engine may crawl on NaN rather than fail). :meth:`BodyGuard.check_all` checks
every body once more when the trial ends.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Generic, TypeVar

import numpy as np

from ltamp_cli.backends.protocol import SkillBackend, SkillSpec, TrialResult, skill_spec
from ltamp_cli.trials.record import MAX_SCORE_MAGNITUDE

# Longest error message kept in a failed trial's record (one line).
REASON_CHARS = 300

Body = TypeVar("Body")
#: One body's ``(position, linear velocity)``, each a tuple of 2 or 3 floats.
BodyState = tuple[Sequence[float], Sequence[float]]


@dataclass(frozen=True)
class StateLimits:
    """Bounds no sane trial reaches. Units: the backend's length unit (m, or Box2D units)."""

    max_position: float = 100.0
    max_speed: float = 1e3

    def violation(self, positions: np.ndarray, velocities: np.ndarray) -> tuple[int, str] | None:
        """``(first bad body, what is wrong)`` or ``None``; inputs are ``(n, d)``."""
        positions = np.atleast_2d(np.asarray(positions, dtype=float))
        velocities = np.atleast_2d(np.asarray(velocities, dtype=float))
        checks = (
            (~np.isfinite(positions).all(axis=1), "non-finite position"),
            (~np.isfinite(velocities).all(axis=1), "non-finite velocity"),
            (np.abs(positions).max(axis=1, initial=0.0) > self.max_position,
             f"|position| > {self.max_position:g}"),
            (np.linalg.norm(velocities, axis=1) > self.max_speed,
             f"speed > {self.max_speed:g}"),
        )  # fmt: skip
        for bad, what in checks:
            if bad.any():
                return int(np.argmax(bad)), f"{what} ({int(bad.sum())} of {len(bad)} bodies)"
        return None


class PhysicsDiverged(Exception):
    """Raised inside a trial when its simulation diverged; ``reason`` says how (one line)."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason

    def result(self, invalid_score: float) -> TrialResult:
        """The invalid trial this divergence makes."""
        return TrialResult(invalid_score, False, {"reason": f"physics diverged: {self.reason}"})


class DivergenceGuard:
    """Counts steps and checks states every ``every`` steps, raising :class:`PhysicsDiverged`."""

    def __init__(self, every: int = 10, limits: StateLimits | None = None) -> None:
        if every < 1:
            raise ValueError(f"every must be >= 1, got {every}")
        self.every = every
        self.limits = limits or StateLimits()
        self.steps = 0

    def due(self) -> bool:
        """Count one step; whether the states should be checked now."""
        self.steps += 1
        return self.steps % self.every == 0

    def check(
        self, positions: np.ndarray, velocities: np.ndarray, name_of: Callable[[int], str]
    ) -> None:
        """Raise if any body's state is absurd; ``name_of(i)`` names body ``i`` for the reason."""
        found = self.limits.violation(positions, velocities)
        if found is not None:
            body, what = found
            raise PhysicsDiverged(f"{what}, first {name_of(body)}, after {self.steps} steps")


class BodyGuard(Generic[Body]):
    """Checks a backend's bodies while a trial runs (see the module docstring).

    ``bodies()`` lists the moving bodies now, ``state(body)`` reads one body's
    :data:`BodyState` and ``name(body)`` names it for the reason of a divergence.
    """

    def __init__(
        self,
        bodies: Callable[[], list[Body]],
        state: Callable[[Body], BodyState],
        name: Callable[[Body], str],
        every: int = 20,
        limits: StateLimits | None = None,
    ) -> None:
        self.bodies, self.state, self.name = bodies, state, name
        self.guard = DivergenceGuard(every, limits)
        self._cached: list[Body] | None = None

    def step(self, refresh: bool = False) -> None:
        """After one simulation step: check this step's slice (``refresh``: the bodies changed)."""
        due = self.guard.due()
        if due or refresh or self._cached is None:  # bodies come and go (spawned, frozen)
            self._cached = self.bodies()
        every = self.guard.every
        self._check(self._cached[self.guard.steps % every :: every])

    def check_all(self) -> None:
        """Check every body now (at the end of a trial)."""
        self._check(self.bodies())

    def _check(self, bodies: list[Body]) -> None:
        # Plain loops, not numpy: this runs after every step and the slices are small, so call
        # overhead is what counts. NaN fails every comparison, so it breaks out too.
        limits, state = self.guard.limits, self.state
        reach, speed2 = limits.max_position, limits.max_speed * limits.max_speed
        for body in bodies:
            position, velocity = state(body)
            total = 0.0
            for value in velocity:
                total += value * value
            if not total <= speed2:
                break
            if not all(abs(value) <= reach for value in position):
                break
        else:
            return
        # Something is off: describe it over every body.
        everyone = self.bodies()
        states = [self.state(body) for body in everyone]
        positions = np.array([position for position, _ in states], dtype=float)
        velocities = np.array([velocity for _, velocity in states], dtype=float)
        self.guard.check(positions, velocities, lambda i: self.name(everyone[i]))


def run_guarded(
    guard: BodyGuard[Body],
    run: Callable[[Callable[[int], None]], TrialResult],
    on_step: Callable[[int], None] | None,
    invalid_score: float,
) -> TrialResult:
    """``run(step_callback)`` with ``guard`` checking bodies after every step it reports
    (then calling ``on_step``) and at the end; a divergence gives the invalid trial."""

    def step(index: int) -> None:
        guard.step()
        if on_step is not None:
            on_step(index)

    try:
        result = run(step)
        guard.check_all()
    except PhysicsDiverged as diverged:
        return diverged.result(invalid_score)
    return result


def failed_result(invalid_score: float, reason: str) -> TrialResult:
    """An invalid trial with the skill's ``invalid_score`` and a one-line ``reason``."""
    line = " ".join(reason.split())[:REASON_CHARS]
    return TrialResult(invalid_score, False, {"reason": line})


def run_trial_safely(
    backend: SkillBackend, skill: str, context: np.ndarray, control: np.ndarray, seed: int
) -> tuple[TrialResult, bool]:
    """``(result, crashed)`` of ``backend.run_trial``, never raising for one trial's physics.

    A trial that raises (``crashed``: the backend's world may be left mid-trial), returns
    something other than a :class:`TrialResult`, scores a non-finite value or one beyond
    ``±MAX_SCORE_MAGNITUDE`` or reports measurements that are not strict JSON (NaN, inf) is
    an invalid trial with the skill's invalid score and the reason in ``info["reason"]``. So
    is a valid trial of a skill that declares an outcome (``SkillSpec.outcome``) whose
    reported outcome is missing, malformed, far out of its range, or does not reproduce the
    trial's score through the declared score function (:func:`checked_outcome`). The
    returned result's ``outcome`` is a tuple of floats for such a skill's valid trials and
    ``None`` otherwise (an undeclared outcome is dropped).
    The score may be any real number type (``int``, numpy scalars, a 0-d array) and comes
    back as a ``float``; a ``bool`` score is a success label, ``True`` -> ``+1.0`` and
    ``False`` -> ``-1.0``. ``valid`` must be a bool (or 0/1; a string ``"false"`` is no answer).
    An invalid trial scoring above 0 (a "success" that could not be run) gets the invalid
    score, with the reason; invalid trials' scores ≤ 0 are kept.
    """
    spec = skill_spec(backend, skill)
    invalid_score = spec.invalid_score
    try:
        result = backend.run_trial(skill, context, control, seed)
    except Exception as error:  # one trial's physics must not end a collection or training
        return failed_result(invalid_score, f"trial raised {type(error).__name__}: {error}"), True
    if not isinstance(result, TrialResult):  # a plugin's run_trial returned None, a float...
        return failed_result(invalid_score, f"run_trial returned {result!r:.60}, not a "
                                            "TrialResult"), False
    raw = result.score
    if isinstance(raw, np.ndarray) and raw.shape == ():
        raw = raw[()]  # a 0-d array: its one value
    if isinstance(raw, bool | np.bool_):
        # a success label: a failure must lie below the level g = 0, not on it (as 0.0 it
        # would, and the level set of failures scored 0 and successes 1 is undefined)
        raw = 1.0 if raw else -1.0
    try:
        if isinstance(raw, str | bytes):
            raise TypeError(raw)
        score = float(raw)
    except (TypeError, ValueError):
        return failed_result(invalid_score, f"score {result.score!r:.40} is no number"), False
    if not (isinstance(result.valid, bool | np.bool_)
            or (isinstance(result.valid, int | np.integer) and result.valid in (0, 1))):
        return failed_result(invalid_score, f"valid {result.valid!r:.40} is not True or "
                                            "False"), False
    if not math.isfinite(score):
        return failed_result(invalid_score, f"non-finite score {result.score}"), False
    if abs(score) > MAX_SCORE_MAGNITUDE:  # a learner's arithmetic would overflow on it
        return failed_result(invalid_score, f"score {score:g} beyond "
                                            f"±{MAX_SCORE_MAGNITUDE:g}"), False
    try:  # a record must be strict JSON; NaN in the measurements means the physics went wrong
        json.dumps(dict(result.info), allow_nan=False)
    except (TypeError, ValueError) as error:
        return failed_result(invalid_score, f"unrecordable trial info: {error}"), False
    if not result.valid and score > invalid_score and score > 0:
        # A trial that could not be run cannot have succeeded: learned as is, its score
        # would teach the GP a success there (evaluate counts valid successes only).
        reason = failed_result(invalid_score, f"invalid trial reported score {score:g} > 0 "
                                              "(a success)").info["reason"]
        return TrialResult(invalid_score, False, {**dict(result.info), "reason": reason}), False
    result = TrialResult(score, bool(result.valid), result.info, result.outcome)
    if spec.outcome is None or not result.valid:
        return (result if result.outcome is None else replace(result, outcome=None)), False
    try:
        outcome = checked_outcome(spec, context, control, score, result.outcome)
    except ValueError as error:
        return failed_result(invalid_score, f"bad outcome: {error}"), False
    return replace(result, outcome=outcome), False


#: Largest difference between a trial's score and the one its declared outcome score function
#: gives (absolute, plus the same relative to the score's magnitude).
OUTCOME_SCORE_TOLERANCE = 1e-6


def checked_outcome(spec: SkillSpec, context: np.ndarray, control: np.ndarray, score: float,
                    outcome: object) -> tuple[float, ...]:
    """``outcome`` as a tuple of floats if it fits ``spec.outcome`` (which must be declared):
    the declared length, finite, within one box width of its range, and reproducing
    ``score`` through the declared score function; else ``ValueError`` (one line)."""
    assert spec.outcome is not None
    if outcome is None:
        raise ValueError("the skill declares an outcome but the trial reported none")
    values = spec.outcome.check(outcome)
    try:
        again = float(spec.outcome.scores(np.asarray(context, dtype=float)[None, :],
                                          np.asarray(control, dtype=float)[None, :],
                                          np.asarray(values)[None, :])[0])
    except Exception as error:  # a plugin's score function: any failure is one line
        raise ValueError(f"the declared score function failed: "
                         f"{type(error).__name__}: {error}") from None
    if abs(again - score) > OUTCOME_SCORE_TOLERANCE * (1.0 + abs(score)):
        raise ValueError(f"the declared score function gives {again:g} from the outcome, "
                         f"the trial scored {score:g}")
    return values
