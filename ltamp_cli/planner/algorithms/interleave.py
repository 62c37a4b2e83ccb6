"""The incremental algorithm interleaved with an optimistic one: a two-member portfolio.

The optimistic algorithms (adaptive, binding, focused) plan with placeholders for stream
outputs and call only what a plan needs. When the optimistic plans keep exploiting a
placeholder that no real value can fill (a robot's kinematics at poses it cannot reach, one
placeholder configuration standing for two robots' kinematics), each search finds the same
hope again over a fresh sample, and the solve can run out of time on a problem that the
incremental algorithm, which calls every stream instance over the real objects level by
level and searches the real facts only, solves in a few rounds (issue #19's hidden suite:
handoff_2, incremental 0.16 s CPU, adaptive no plan in 60 s; chain_4 and regions3_4,
incremental 10x faster).

Neither member is better on every problem, so the solve runs both, in one thread, in
turns decided by **work units** (:func:`work_units`: stream calls, facts and ground
actions of searched tasks, evaluated states, each weighted by its typical CPU cost), never
by a clock, so that when each member runs, and so which member's plan a seed returns, is
the same on a quiet and a loaded machine (a CPU-timed share made them depend on the load;
the algorithms' own CPU-timed rule, :func:`.effort.observed_cheap`, still is: a stream
whose mean CPU per call lies near its 250 us threshold can be decided either way):

* for its first :data:`GRACE_UNITS` of work the optimistic member runs alone, so the solves
  that meet the issue's latency targets (uniform tamp2d problems, examples) do exactly what
  they did before, plans included;
* after that, between two iterations of the optimistic loop, the incremental member runs
  until its own work reaches :data:`SHARE` times the work the optimistic member did past
  the grace. Its work is cut at every stream call (those of its eager fixpoints too) and
  every search (:func:`.incremental.incremental_steps` is resumable); a step that
  overshoots the share (a search) is a debt the member waits out.

Whichever member finds a plan first returns it; an "infeasible" from the incremental member
is a proof (every instance exhausted, an exhaustive search) and is returned too. An
"infeasible" of the optimistic member that is not a proof (:mod:`ltamp_cli.planner.api`)
runs the incremental member on to its end (:meth:`InterleavedIncremental.finish`). With
share ``s``, a problem that incremental alone solves with ``w`` units is solved after
about ``GRACE_UNITS + (1 + 1/s) w`` whatever the optimistic member does, and one that the
optimistic member alone solves with ``w > GRACE_UNITS`` after about
``w + s (w - GRACE_UNITS)`` (plus one step of the member). A unit costs the optimistic
member about as much CPU as the incremental member (1.14 and 1.11 us on the hidden
suite), so ``s = 0.4`` is about 0.4 of the CPU: a little more than the third of the
CPU-timed share it replaces, which makes up for a grace of ~0.28 s rather than 0.25 s, so
that incremental wins (hidden chain_4: 0.14 million units) are not slower. The optimistic
member, the better one on most problems, keeps about 70 % of the CPU past the grace, and
incremental wins are kept within the issue's 10x. Equal shares (``s = 1``,
measured first) slowed the optimistic member's own solves twofold (hidden obstacles_3:
5/5 -> 2/5 solved in 60 s at load 18; regions3_4 0.65 -> 1.05 s median CPU) for little
gain where the member wins (docs/results/planner/issue19.md).

Stream calls all count alike, whatever they cost: with streams far costlier than the
planner's own steps (learned samplers of a millisecond or more) the grace lasts longer in
CPU and the member, which calls every instance, takes more than its share of the CPU
(``stats["interleaved"]`` reports its CPU beside its units).

The incremental member has its own :class:`.PlannerState` (made by
:func:`.common.initial_state` from the same problem, configuration and seed, so its stream
generators draw what a plain incremental solve would draw) and is created only once the
grace has passed, once per solve: the anytime rounds of a solve (``success_cost``) go on
with the same member, its samples and work (:meth:`InterleavedIncremental.next_round`), so
a solve calls the bindings' ``make_streams`` for it (a physics world in 3D domains: setup,
not counted as the member's work) once. The member's stream calls are added to the solve's
statistics (``stats["streams"]``, the persisted history) beside the optimistic member's.
The optimistic member's state, its statistics and its decisions are left exactly as
without the portfolio (running the member on the optimistic state, sharing its facts, was
measured and not kept: slower, see docs/results/planner/issue19.md, hidden-suite
session 3). Not run when the incremental algorithm does not apply: streams with
``:fluents`` (it cannot call them in the states a plan visits), no streams at all (nothing
to sample), or ``PlannerConfig.interleave`` off. With the drop-in API, whose samplers may
draw from the user's own global random state, both members draw from it.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Generator
from dataclasses import dataclass, replace

from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import PlannerState, WorkCount, initial_state
from ltamp_cli.planner.algorithms.companions import missed_outputs
from ltamp_cli.planner.algorithms.incremental import incremental_steps
from ltamp_cli.planner.result import INFEASIBLE, SOLVED, PlanResult
from ltamp_cli.planner.watchdog import RunningCall

# Work units per counted item (:class:`.common.WorkCount`), so that a unit is about a
# microsecond of CPU on the machine the project's benchmarks ran on (fitted by least
# squares to the CPU of optimistic-only and incremental solves of the uniform suite, the
# examples and the hidden suite, docs/results/planner/issue19.md: CPU / units median 1.01,
# 10-90 % 0.85-1.50; on the hidden suite 1.14 for adaptive alone, 1.11 for incremental):
# a stream call, a fact of a searched task's initial state, a ground action or axiom, a
# state a search evaluated, and such a state per ground action or axiom of its task.
# Deterministic counts, not seconds: the sequence of both members' steps, and so the plan
# a seed returns, does not depend on the machine's load (only ``max_time`` is a clock).
CALL_UNITS = 12.0
# A stream call's CPU past ``common.SLOW_CALL_US`` (10 ms), in microseconds: 3D coffee's
# calls (motion plans, IK, physics pre-checks) take 0.1-3 s; counted as 12 units each they
# let the member take 149 of a timed-out solve's 155 s of CPU (seeds 0 and 2; 36 s without
# the member).
SLOW_CALL_UNITS = 1.0
FACT_UNITS = 5.0
GROUND_UNITS = 55.0
EVALUATED_UNITS = 90.0
HEURISTIC_UNITS = 0.04
# Work units the optimistic member runs alone: about 0.28 s of its CPU, just above the
# issue's latency target for the largest uniform tamp2d problem (8 blocks, 0.25 s median),
# so that solves meeting the targets are untouched (the costliest of them that took less
# than 0.25 s CPU, uniform tight_4 binding seed 0, counts 262,000). Not tuned on a
# problem: a smaller grace only starts the portfolio earlier.
GRACE_UNITS = 270_000.0
# Work units of the incremental member per unit of the optimistic member's past the grace:
# about 0.4 of its CPU (see the module docstring: the optimistic member about 1.4x slower
# past the grace, an incremental win about 3.5x slower plus the grace).
SHARE = 0.4
# ``stats["solved_by"]`` of a result that the incremental member made.
MEMBER = "interleaved incremental"


def work_units(work: WorkCount) -> float:
    """``work`` in work units (about microseconds of CPU, see :data:`CALL_UNITS`)."""
    return (CALL_UNITS * work.calls + FACT_UNITS * work.facts + GROUND_UNITS * work.grounded
            + EVALUATED_UNITS * work.evaluated + HEURISTIC_UNITS * work.heuristic
            + SLOW_CALL_UNITS * work.slow_call_us)


@dataclass
class InterleavedIncremental:
    """The incremental member of a solve (see the module's docstring), one per solve:
    every anytime round goes on with it (:meth:`next_round`). ``started``: the optimistic
    member's work units when the solve started; ``clock``: CPU seconds of the solving
    thread (``PlannerConfig.stream_cpu_clock`` when injected), only to report the member's
    CPU, never to decide."""

    optimistic: PlannerState
    clock: Callable[[], float]
    started: float
    member: PlannerState | None = None
    steps: Generator[None, None, PlanResult] | None = None
    cpu_s: float = 0.0  # CPU seconds of the incremental member's steps (reported only)
    setup_cpu_s: float = 0.0  # CPU seconds of its make_streams (setup, not a step)
    slices: int = 0
    rounds: int = 1  # anytime rounds of the solve served (see next_round)
    finished: bool = False
    ended: str | None = None  # the status its steps ended with (when finished)
    skipped: str | None = None  # why the member could not be made (see _make_member)
    unproven: str | None = None  # why its "infeasible" was no proof (.companions)
    continued: bool = False  # run on to its end after the optimistic member stopped

    def spent(self) -> float:
        """Work units of the incremental member so far."""
        return 0.0 if self.member is None else work_units(self.member.work)

    def allowance(self) -> float:
        """Work units the incremental member may still use now (<= 0: none)."""
        optimistic = work_units(self.optimistic.work) - self.started
        return SHARE * (optimistic - GRACE_UNITS) - self.spent()

    def run(self) -> PlanResult | None:
        """Advance the incremental member for its share of work; its result when it solved
        the problem or proved it infeasible (``None``: go on with the optimistic member).
        A step that overshoots the share (a search) is a debt the member waits out."""
        if self.finished or self.optimistic.timed_out() or self.allowance() <= 0:
            return None
        result = self._advance(within_share=True)
        return None if result is None else self._outcome(result)

    def finish(self) -> PlanResult | None:
        """Run the incremental member to its end, for the time left (after the optimistic
        member stopped without a plan); its result, ``None`` when it had ended already."""
        if self.finished:
            return None
        self.continued = True
        result = self._advance(within_share=False)
        return None if result is None else self.of_member(result)

    def next_round(self) -> None:
        """Go on into the solve's next anytime round, in which the optimistic state asks
        for plans cheaper than its ``cost_bound``: the same member (no second
        ``make_streams``, no new grace: its work and the optimistic member's count from the
        solve's start), under the same bound. A member whose plan ended the last round
        searches again over the samples it has (a new run of its steps over the same
        state: its instances, objects and search budget are kept); one that ended
        otherwise (a proof, a timeout, an "infeasible" that proved nothing) stays ended."""
        self.rounds += 1
        if self.member is None:
            return
        self.member.cost_bound = self.optimistic.cost_bound
        if self.finished and self.ended == SOLVED:
            self.steps = incremental_steps(self.member)
            self.finished = False
            self.ended = None

    def _advance(self, within_share: bool) -> PlanResult | None:
        """Step the member (made on first use) while it has allowance (``within_share``)
        or to its end; its result once it ended, else ``None``. Making it (the bindings'
        ``make_streams``: a physics world in 3D domains) is setup, as the optimistic
        member's own is: reported apart (:attr:`setup_cpu_s`), neither a step nor work."""
        if self.steps is None:
            start = self.clock()
            self.member = self._make_member()
            self.setup_cpu_s += self.clock() - start
            if self.member is None:
                self.finished = True
                return None
            self.steps = incremental_steps(self.member)
        start = self.clock()
        try:
            self.slices += 1
            while not within_share or self.allowance() > 0:
                try:
                    next(self.steps)
                except StopIteration as done:
                    self.finished = True
                    self.ended = done.value.status
                    return done.value  # type: ignore[no-any-return]
            return None
        finally:
            self.cpu_s += self.clock() - start

    def _make_member(self) -> PlannerState | None:
        """The member's state (``None``, the reason in :attr:`skipped`, when the bindings'
        ``make_streams`` refuses a second call: a resource held once per process, such as a
        PyBullet GUI connection; the optimistic member, which has its bindings, goes on
        alone rather than the solve failing where it would not without the portfolio)."""
        state = self.optimistic
        tracker = state.tracker
        tracker.running = RunningCall("make_streams", (), time.perf_counter())
        try:
            member = initial_state(state.problem,
                                   replace(state.config, algorithm="incremental"))
        except InputError as error:  # initial_state's one line for a failed make_streams
            self.skipped = error.message
            return None
        finally:
            tracker.running = None
        member.start_time = state.start_time  # the same deadline
        member.tracker = state.tracker  # the watchdog follows (and may cancel) its calls
        member.history = state.history
        if state.cost_bound is not None:
            member.cost_bound = state.cost_bound  # anytime mode: only cheaper plans
        state.companions.append(member)  # its outputs check an "infeasible" (companions)
        return member

    def _outcome(self, result: PlanResult) -> PlanResult | None:
        """The member's result when it settles the solve (solved, or proven infeasible);
        labelled with the solve's algorithm."""
        if result.status not in (SOLVED, INFEASIBLE):
            return None
        if result.status == INFEASIBLE and self.member is not None:
            missed = missed_outputs(self.member, [self.optimistic,
                                                  *self.optimistic.companions])
            if missed is not None:  # values went to the optimistic member: no proof
                self.unproven = missed
                return None
        result.stats["algorithm"] = self.optimistic.config.algorithm
        return self.of_member(result)

    def of_member(self, result: PlanResult) -> PlanResult:
        """``result``, made by the member's state: labelled ``solved_by`` the member when
        it settles the solve, with the optimistic member's work added (:func:`add_work`)
        and the member's recorded."""
        if result.status in (SOLVED, INFEASIBLE):
            result.stats["solved_by"] = MEMBER
        add_work(result, self.optimistic)
        return self._record(result)

    def annotate(self, result: PlanResult) -> PlanResult:
        """Record the member's work in ``result.stats["interleaved"]`` (when it ran); a
        result of the optimistic member's state gets the member's searches, seconds and
        stream calls added (:func:`add_work`) the first time (a result that has the record
        already was made by :meth:`of_member` or seen before)."""
        if self.member is not None and "interleaved" not in result.stats:
            add_work(result, self.member)
        return self._record(result)

    def _record(self, result: PlanResult) -> PlanResult:
        """Set ``result.stats["interleaved"]``: the member's work, or why it was skipped."""
        if self.skipped is not None:
            result.stats["interleaved"] = {"skipped": self.skipped}
        if self.unproven is not None:
            result.stats["interleaved_infeasibility_unproven"] = self.unproven
        if self.member is not None:
            result.stats["interleaved"] = {
                "slices": self.slices, "continued": self.continued, "rounds": self.rounds,
                "cpu_s": round(self.cpu_s, 6), "setup_cpu_s": round(self.setup_cpu_s, 6),
                "work_units": round(self.spent()),
                "optimistic_work_units": round(work_units(self.optimistic.work)
                                               - self.started),
                "searches": self.member.searches, "iterations": self.member.iterations,
                "stream_calls": sum(s.calls for s in self.member.stream_stats.values())}
        return result


def add_work(result: PlanResult, other: PlannerState) -> None:
    """Add what ``other`` (the solve's other member) did to ``result``'s statistics: its
    searches, iterations, seconds (search, grounding, stream calls) and, per stream, its
    calls, successes, outputs and seconds, so that ``--json`` shows the whole solve. One
    thread ran both members, so the seconds add up to at most the solve's."""
    stats = result.stats
    stats["searches"] += other.searches
    stats["iterations"] += other.iterations
    for key, seconds in (("search_time_s", other.search_time),
                         ("grounding_time_s", other.grounding_time),
                         ("sampling_time_s", other.sampling_time)):
        stats[key] = round(stats[key] + seconds, 6)
    streams = stats.setdefault("streams", {})
    for name, calls in other.stream_stats.items():
        mine = streams.setdefault(name, {"calls": 0, "successes": 0, "outputs": 0,
                                         "time_s": 0.0})
        for key, value in calls.as_dict().items():
            mine[key] = round(mine[key] + value, 6) if key == "time_s" else mine[key] + value
    stats["streams"] = dict(sorted(streams.items()))


def interleaved_incremental(state: PlannerState) -> InterleavedIncremental | None:
    """The incremental member for an optimistic solve of ``state`` (``None`` when it does not
    apply: see the module's docstring)."""
    stream_file = state.problem.stream_file
    if (not state.config.interleave or state.config.algorithm == "incremental"
            or stream_file is None or any(s.fluents for s in stream_file.streams)):
        return None
    clock = state.config.stream_cpu_clock or time.thread_time
    return InterleavedIncremental(state, clock, work_units(state.work))
