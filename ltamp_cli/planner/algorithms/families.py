"""Stream families: success statistics of a stream's instances grouped by where their
inputs come from, so that a hope that fails for every sample of a generator stops being
renewed by each fresh sample.

A *family* is a stream together with a description of each of its inputs: an object of
the problem is described by its name, a value made by a stream call (or an optimistic
placeholder) by its *origin*, the producing stream and the problem objects among that
producer's inputs (a sampled input of the producer is ``*``). So ``inverse-kinematics(r1,
a, p, g)`` with ``p`` from ``sample-pose(a, goal)`` and ``g`` from ``sample-grasp(a)`` is in
family ``inverse-kinematics(r1, a, sample-pose(a, goal), sample-grasp(a))``, whatever the
sampled values, and so is the optimistic instance over the placeholders of the next
samples of those generators.

Why: ``StreamStats`` are per stream, and a failed instance is disabled alone. When a robot
cannot reach a region, every pose sampled there gives a new kinematics instance that
fails, and each new sample renews the optimistic plan that uses it (the hidden suite's
handoff_2: 18 failed calls of ``inverse-kinematics(r1, a, pose in goal, .)``, one search
each, and no success). A family with no success in :data:`FAMILY_MIN_FAILURES` calls or
more gets a level *penalty* that doubles with each failure, up to :data:`MAX_PENALTY`
(:meth:`StreamFamilies.penalty`; a linear or logarithmic one was outgrown by the bounds
the search reaches, ``docs/results/planner/issue19.md``); the optimistic evaluation adds
it to the summed level of the family's new instances, so the plans that need them come
after the others at the same bound. Never a cut: the penalty is finite and left out of
the level by PDDLStream's rule, which decides "infeasible"
(:func:`.optimistic.within_limit`), so a penalised family only waits for a higher bound.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

# Description of one input: a problem object's name, or (producing stream, its inputs with
# every value that is not a problem object replaced by "*").
Origin = tuple[str, tuple[str, ...]]
Descriptor = str | Origin
FamilyKey = tuple[str, tuple[Descriptor, ...]]

# Calls without a success before a family's instances are penalised: 2 failures in a row
# is already unlikely for a stream that succeeds half the time, and a penalty of one level
# costs little when it is wrong (the instances come back one bound later).
FAMILY_MIN_FAILURES = 2
WILDCARD = "*"
# Sampled inputs described both ways in every combination up to this many (2^3 families).
MAX_EXACT_COMBINATIONS = 3
# The highest penalty (levels, retries): far above the bounds a solve reaches in practice.
MAX_PENALTY = 64


def origin(stream: str, inputs: tuple[str, ...], problem_objects: Mapping[str, object]
           ) -> Origin:
    """How a value made by instance ``(stream, inputs)`` is described in a family."""
    return (stream, tuple(x if x in problem_objects else WILDCARD for x in inputs))


@dataclass
class FamilyCounts:
    calls: int = 0
    successes: int = 0


@dataclass
class StreamFamilies:
    """Per-family call counts of one solve (see the module docstring).

    ``origins``: value name -> its :data:`Origin` (the first call that made it);
    ``counts``: family -> calls and successes; ``failing``: stream name -> number of its
    families without a success that are penalised (a stream without such a family costs
    the optimistic evaluation nothing)."""

    origins: dict[str, Origin] = field(default_factory=dict)
    counts: dict[FamilyKey, FamilyCounts] = field(default_factory=dict)
    failing: dict[str, int] = field(default_factory=dict)

    def families(self, stream: str, inputs: tuple[str, ...],
                 problem_objects: Mapping[str, object],
                 placeholder_origin: Callable[[str], Origin | None] | None = None
                 ) -> list[FamilyKey]:
        """The families of instance ``(stream, inputs)``, coarse to fine: each input that
        is a real value made by a stream is described by its origin, or by itself (so
        that a sampled pose that no grasp makes reachable is learned as such, while the
        pose sampler's other poses are not blamed); a placeholder only by its origin
        (``placeholder_origin``). At most :data:`MAX_EXACT_COMBINATIONS` inputs are
        varied jointly; beyond that, one at a time."""
        options: list[list[Descriptor]] = []
        varied = 0
        for value in inputs:
            if value in problem_objects:
                options.append([value])
                continue
            found = self.origins.get(value)
            if found is not None:
                options.append([found, value])
                varied += 1
                continue
            found = placeholder_origin(value) if placeholder_origin is not None else None
            options.append([WILDCARD if found is None else found])
        coarse = tuple(option[0] for option in options)
        if varied <= MAX_EXACT_COMBINATIONS:
            return [(stream, combination) for combination in itertools.product(*options)]
        singles = [(stream, (*coarse[:i], option[1], *coarse[i + 1:]))
                   for i, option in enumerate(options) if len(option) > 1]
        return [(stream, coarse), *singles]

    def record(self, stream: str, inputs: tuple[str, ...], success: bool,
               outputs: list[tuple[str, ...]], problem_objects: Mapping[str, object]) -> None:
        """Count one call of ``(stream, inputs)`` in each of its families; its new
        ``outputs`` get their origin."""
        for key in self.families(stream, inputs, problem_objects):
            counts = self.counts.setdefault(key, FamilyCounts())
            was_failing = counts.successes == 0 and counts.calls >= FAMILY_MIN_FAILURES
            counts.calls += 1
            counts.successes += int(success)
            failing = counts.successes == 0 and counts.calls >= FAMILY_MIN_FAILURES
            if failing != was_failing:
                self.failing[stream] = self.failing.get(stream, 0) + (1 if failing else -1)
        if outputs:
            made = origin(stream, inputs, problem_objects)
            for output in outputs:
                for value in output:
                    if value not in problem_objects:
                        self.origins.setdefault(value, made)

    def instance_penalty(self, stream: str, inputs: tuple[str, ...],
                         problem_objects: Mapping[str, object],
                         placeholder_origin: Callable[[str], Origin | None] | None = None
                         ) -> int:
        """The highest :meth:`penalty` of the instance's families (0 without a failing
        family of ``stream``)."""
        if not self.has_failing(stream):
            return 0
        return max(self.penalty(key) for key in self.families(
            stream, inputs, problem_objects, placeholder_origin))

    def has_failing(self, stream: str) -> bool:
        return self.failing.get(stream, 0) > 0

    def penalty(self, key: FamilyKey) -> int:
        """Extra levels for a new instance of family ``key``: 0 unless it had no success in
        at least :data:`FAMILY_MIN_FAILURES` calls; then ``2 ** failures`` levels, at most
        :data:`MAX_PENALTY` (2 -> 4, 3 -> 8, 6 or more -> 64)."""
        counts = self.counts.get(key)
        if counts is None or counts.successes or counts.calls < FAMILY_MIN_FAILURES:
            return 0
        return min(2 ** counts.calls, MAX_PENALTY)
