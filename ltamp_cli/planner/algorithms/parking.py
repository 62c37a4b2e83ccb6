"""Parked samples: values a binding's test rejected stay out of later optimistic tasks.

Why (issue #19, crowded regions): with placement samplers that know nothing of other
blocks, most samples of a stream plan fail one of its tests (the pose collides with a
block standing in the goal region, or with the pose sampled just before). Each such sample
stays a real object, and with an eager pairwise test (collision between every two poses)
it adds a row of test calls and facts to **every later task**: on ``hidden_clutter_10``
418 poses gave 183,000 collision tests and 34,000-fact tasks, 0.7-1.1 s a search, most of
it for poses no plan used. PDDLStream's adaptive keeps such tasks small another way (its
collision test is a negated stream: only failures enter the task, and only the pairs a
plan's preimage needs are tested); here the values are set aside instead.

The rule: when a test on a binding's path rejects values, the value that binding sampled
last among them (the generator output the local repair would replace) is *parked*. A
parked value

* keeps its facts in the store (a binding that holds it goes on using it; its instances
  and outputs are kept for reuse), but
* no fact that mentions it enters an optimistic task, no optimistic instance takes it as
  an input, and eager streams are not called on input tuples that hold it (they wait in
  :attr:`ParkedSamples.held`).

Parking starts once an optimistic task has reached :data:`PARK_ABOVE_TASK_FACTS` facts and
stays on for the rest of the solve. Below that a search is cheap, and what a rejected
sample is worth is its reuse: two blocks that must fit side by side in a tight region
are placed from a pool of earlier samples, and parking those took the tight placements of
``tests/planner/test_cheap_tests_eager.py`` from at most 10 searches a seed to 18, and
``tamp2d_uniform_tight_6`` adaptive from 0.10 to 0.16 s median CPU.

Completeness: a task that leaves parked values out is *cut* (it does not prove
"infeasible"), and when a full search (not a speculative one) proves that it has no plan
(it did not run out of expansions), every value is released (:meth:`ParkedSamples.release`)
and the same bound is searched again, so the next tasks see all samples and the eager
calls that waited are made; a search that ran out of expansions keeps them parked (its
budget doubles, so an exhaustive failure comes). Soundness: a plan that needs no stream,
found while values are parked, is checked over every real fact before it is returned (a
derived condition such as "no block in the way" may hold in the task only because a fact
was left out), and the problem's own objects are never parked.
"""

from __future__ import annotations

from collections.abc import Container, Iterable, Mapping
from dataclasses import dataclass, field

Fact = tuple[str, ...]

# Facts of an optimistic task from which on rejected samples are parked (a search over
# ~8,000 facts takes ~0.2 s here). The largest tasks of the uniform suite (8 blocks) and
# kitchen_fluent have 5,500 and 2,000 facts; hidden_clutter_10's reach 35,000-80,000.
PARK_ABOVE_TASK_FACTS = 8_000


@dataclass
class ParkedSamples:
    """Sampled object names set aside (see the module docstring), and the eager input
    tuples that wait for them (stream name -> tuples)."""

    values: set[str] = field(default_factory=set)
    held: dict[str, list[tuple[str, ...]]] = field(default_factory=dict)
    parked_total: int = 0  # values parked over the solve (a value parked twice counts twice)
    releases: int = 0
    active: bool = False  # a task has reached PARK_ABOVE_TASK_FACTS facts

    def note_task(self, facts: int) -> None:
        """An optimistic task of ``facts`` facts was built: parking starts at the
        threshold and stays on."""
        self.active = self.active or facts >= PARK_ABOVE_TASK_FACTS

    def __bool__(self) -> bool:
        return bool(self.values)

    def park(self, value: str) -> None:
        """Set ``value`` aside (only once parking is :attr:`active`)."""
        if self.active and value not in self.values:
            self.values.add(value)
            self.parked_total += 1

    def holds(self, inputs: Iterable[str]) -> bool:
        """Whether ``inputs`` (an input tuple or a fact's arguments) mention a parked value."""
        values = self.values
        return bool(values) and any(x in values for x in inputs)

    def hold_back(self, name: str, candidates: list[tuple[str, ...]]
                  ) -> list[tuple[str, ...]]:
        """The eager ``candidates`` of stream ``name`` free of parked values; the others
        are kept in :attr:`held` until :meth:`release`."""
        if not self.values:
            return candidates
        free = [inputs for inputs in candidates if not self.holds(inputs)]
        if len(free) < len(candidates):
            self.held.setdefault(name, []).extend(
                inputs for inputs in candidates if self.holds(inputs))
        return free

    def task_facts(self, facts: Iterable[Fact]) -> Iterable[Fact]:
        """``facts`` without those whose arguments mention a parked value."""
        values = self.values
        if not values:
            return facts
        return [fact for fact in facts if not any(x in values for x in fact[1:])]

    def release(self, deferred: dict[str, list[tuple[str, ...]]]) -> None:
        """Unpark every value; the eager tuples that waited go to ``deferred`` (the
        state's deferred eager calls, made at the next eager evaluation)."""
        if not self.values and not self.held:
            return
        for name, waiting in self.held.items():
            deferred.setdefault(name, []).extend(waiting)
        self.held = {}
        self.values = set()
        self.releases += 1

    def stats(self) -> dict[str, int]:
        return {"parked": self.parked_total, "releases": self.releases,
                "parked_now": len(self.values)}


def latest_sample(consumed: Iterable[str], made_by: Mapping[str, object],
                  order: Mapping[str, int], given: Container[str]) -> str | None:
    """Among ``consumed``, the value the binding sampled last: those in ``made_by`` (made
    by one of its generator steps) but not ``given`` (the problem's objects: a sample
    equal to an initial pose is that object, and its facts describe the initial state),
    the one with the highest ``order`` (its creation rank); ``None`` when there is none."""
    sampled = [x for x in consumed if x in made_by and x not in given]
    if not sampled:
        return None
    return max(sampled, key=lambda x: order.get(x, -1))
