"""The binding and adaptive algorithms: plan skeletons in a queue (PDDLStream semantics).

A solved optimistic search yields a *skeleton*: the plan with placeholders and the stream
plan that would make it real. Skeletons are kept in a priority queue of partial bindings;
processing a binding calls the next stream instance of its stream plan with the placeholders
bound so far and branches on its outputs (the first output extends the binding, the next one
is tried later as an alternative). A fully bound skeleton's plan, with its placeholders
replaced by the bound values, is checked in the task over real facts (a bounded search runs
only if it is no plan there). A test that rejects two values sampled by streams asks the
cheap generator of the later one for its next value at once (local repair, see
:data:`.optimistic.MAX_LOCAL_REPAIRS`).

* ``binding`` searches again only when no binding in the queue can progress without more
  retries (alternative outputs, instances that produced nothing) than the current bound;
* ``adaptive`` (the default) also shares effort between searching and sampling: after a
  search it processes a number of bindings proportional to the states the search evaluated,
  then searches again if sampling taught it new facts and a binding step failed. Such a
  speculative search is bounded and changes no bound; a full search that finds nothing new
  raises the retry and complexity bounds. Bindings whose next stream is cheap may be retried
  more often (plain samplers need several samples where a search costs far more), unless
  their skeleton's last failure was a ``:fluents`` stream's (:class:`RetryPolicy`). When a
  full search's share is its floor of one step and searches have found two skeletons or
  more, the bindings within the retry bound are processed first, as ``binding`` does,
  while the streams' CPU time stays below the searches' (see :data:`SEARCH_SAMPLE_RATIO`).

Both learn several conflicts from one failed stream plan: when a cheap generator of it runs
out, its siblings in the plan are tried at once with the plan's tests
(:func:`probe_siblings`); and when a plan's shared placeholders are refined, its cheap
unshared generators over real inputs are tried with its tests before the search that
follows (:func:`probe_refined_plan`); and when a cheap ``:fluents`` generator produces
nothing in a state, its never-called siblings are called in that state
(:func:`probe_context_siblings`). Adaptive's speculative searches leave out the never-called
siblings of generators that failed (:data:`HOLD_BACK_FAILED_SIBLINGS`). A binding's first
call of an instance whose stream family keeps failing (:mod:`.families`) is deferred by as
many retries as the family's penalty, once per step. Adaptive does not count the retries its
cheap bonus
allowed against a later costly step of a skeleton without action costs
(:func:`over_retry_limit`). The full search after a plan whose shared placeholders were
refined may be bounded by the effort of the search that found it (opt-in,
:data:`REFINED_SEARCH_FACTOR`).
"""

from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass, field

from ltamp_cli.planner.algorithms.common import (
    PlannerState,
    bound_plan,
    external_domain,
    external_inputs,
    instantiate_atoms,
)
from ltamp_cli.planner.algorithms.effort import observed_cheap
from ltamp_cli.planner.algorithms.interleave import (
    InterleavedIncremental,
    interleaved_incremental,
)
from ltamp_cli.planner.algorithms.optimistic import (
    MAX_LOCAL_REPAIRS,
    InstanceKey,
    OptimisticEvaluation,
    Placeholders,
    bind_context,
    bindable_stream_plan,
    contextual_stream_plan,
    evaluate_eager,
    failed_siblings,
    optimistic_evaluation,
    record_rejection,
    repairable,
    report_unusable,
    sampled_inputs,
    stream_plan,
    within_limit,
)
from ltamp_cli.planner.algorithms.parking import latest_sample
from ltamp_cli.planner.algorithms.preimage import plan_preimage
from ltamp_cli.planner.pddl.syntax import Stream, StreamFunction
from ltamp_cli.planner.result import INFEASIBLE, SOLVED, TIMEOUT, PlanResult
from ltamp_cli.planner.search.engine import SearchTimeout
from ltamp_cli.planner.search.ground import Fact
from ltamp_cli.planner.search.solve import grounding_signature
from ltamp_cli.planner.streams import StreamInstance

REAL_SEARCH_EXPANSIONS = 500
# Sampling effort after a search, in binding steps per state the search evaluated: a work
# measure rather than seconds, so that runs are deterministic for a given seed. A step may
# cost microseconds (a collision test) or seconds (a learned pour with its physics checks), so
# the ratio stays small: 0.5 saved tamp2d_4blocks a few searches (7-10 -> 6-8) but spent the
# Kitchen3D pour_blocked budget on 42 GoodPour calls for stale skeletons (timeout at 90 s,
# where 0.1 plans in ~20 s CPU).
STEPS_PER_EVALUATION = 0.1
# The same without action costs (no action of any optimistic task so far had a cost, not
# even one whose function value was 0): plan quality is
# then plan length, which the searches after more sampling do not make worse, so the queue
# gets three times the share. kitchen_fluent (no costs), 40 seeds, alternating processes,
# loaded machine: searches 476 -> 378, FF evaluations 55,549 -> 33,477, plans shorter on 13
# seeds and longer on none, paired median CPU -0.14 s (bootstrap 95 % CI -0.28..-0.01).
# With action costs the longer sampling binds the first skeletons where more searches find
# cheaper plans (Kitchen3D pour_blocked at 0.3: seed 0 cost 16.8 -> 17.3, seed 1 21.4 ->
# 24.5), hence the rule (as partial_guess's).
STEPS_PER_EVALUATION_WITHOUT_COSTS = 0.3
# Adaptive: a binding step that calls a cheap stream (observed < 0.25 ms CPU per call) may
# be retried CHEAP_RETRY_FACTOR times as often before a search. With plain uniform samplers
# most stream plans fail on a collision that a few more samples fix (tamp2d_uniform_tight:
# two blocks fit in the goal region for 1 pair of placements in 9): such retries cost
# microseconds where a search to raise the retry bound costs tens of milliseconds. A cheap
# step counts as CHEAP_STEP_COST of a step of the sampling share unless it makes a new
# object: eager streams over new objects and larger tasks to ground cost far more than the
# call (tamp2d_4blocks, whose motions are eager, went from 0.05 to 0.8 s CPU without that).
# 0.25 rather than 0.05 (6 seeds, median CPU): tamp2d_4blocks 0.12 -> 0.095 s (1.0: 0.08 s),
# tamp2d_uniform_tight_8 0.18 -> 0.21 s (1.0: 0.35 s).
CHEAP_STEP_COST = 0.25
CHEAP_RETRY_FACTOR = 10
# Whether retries allowed by the cheap bonus are left out of the count at steps without
# it (see over_retry_limit).
SEPARATE_CHEAP_RETRIES = True
# Adaptive: after a full search (one that may raise the bounds) whose share above is its
# floor of one step, once searches have found two skeletons or more, the bindings within
# the retry bound are processed as ``binding`` processes them (PDDLStream's
# process_complexity) while the stream calls' CPU time stays below this times the searches'
# CPU time (both totals since the start, PDDLStream's ``search_sample_ratio``, default 1),
# then the share. At its floor the share says nothing: a search that follows the head
# binding's guess or expands a handful of states evaluates almost nothing, however costly
# its grounding. With successor-state samplers each step sampled one state that opened one
# more short optimistic plan, so every search found a new skeleton and the bounds never
# grew (PDDLStream's rmmp: timeouts, its shares were 0-1 step; own lock problem,
# tests/pddlstream/test_sampled_levels.py: 5 of seeds 0-7 timed out at 10 s). Measured
# variants: every binding within the bound, no CPU ratio: Kitchen3D pour_blocked seed 0
# called its learned pour 11 times instead of 7 (18.0 vs 13.6 s CPU); only streams observed
# cheap (< 0.25 ms a call): rmmp lost again; also after the first skeleton:
# tamp2d_uniform_blocked_8 seed 1 sampled poses a fixed obstacle rejects (10 poses and 7
# searches instead of 3 and 5); also when the share is larger: kitchen_fluent (shares of
# 15-17 steps) made one more search on seeds 1 and 2 (11 vs 10, 9 vs 8).
SEARCH_SAMPLE_RATIO = 1.0
# Expansion bound of a speculative search (see solve_with_skeletons): this many times the
# most a solved optimistic search needed so far, at least SPECULATIVE_MIN_EXPANSIONS.
SPECULATIVE_FACTOR = 4
SPECULATIVE_MIN_EXPANSIONS = 100
# After this many speculative searches in a row the next search is a full one, which may
# raise the bounds: speculative searches may keep finding fresh skeletons (new samples of a
# pose that always collides, tamp2d_blocked) whose retries would otherwise never stall.
# tamp2d_blocked with a first search budget of one expansion: 3 -> 2 took 7 -> 3 s CPU;
# 1 slowed tamp2d_uniform_tight_4 (6 seeds, median CPU 0.066 -> 0.096 s).
MAX_SPECULATIVE_IN_A_ROW = 2
# Opt-in (0: off, the default): the full search after a plan whose shared placeholders
# were refined (the same task but for the refined instances' own placeholders) bounded by
# this many times the expansions of the search that found that plan (at least
# SPECULATIVE_MIN_EXPANSIONS, at most the budget); when it runs out, the bounds are raised
# as after a full search that found nothing, but the budget is not doubled. At 4 it halved
# the one costly search of PDDLStream's kitchen/run.py under ltamp (a refined task without
# a plan: 601 -> 297 expansions, 0.42 -> 0.36 s CPU, same plan), but made the unseeded
# continuous_tamp/run.py's plans costlier more often (12 runs each: 13-17 actions, cost
# 125-157, in 4 runs with it, 1 without; else 9 actions, cost ~95): a refined search there
# that runs out raises the complexity, and plans at a higher complexity are longer
# (docs/results/planner/issue19.md).
REFINED_SEARCH_FACTOR = 0


@dataclass
class RetryPolicy:
    """Whether a skeleton's bindings may retry cheap generators more often (adaptive's
    :data:`CHEAP_RETRY_FACTOR`): unless its last failure was that of a ``:fluents`` stream
    (:func:`state_dependent`). The red-team rover (tests/planner/test_cheap_retries.py):
    a route home from every sampled rock configuration fails while debris lies across the
    way; each cheap retry drew one more configuration, i.e. one more optimistic plan
    driving there directly, one more skeleton failing at once, and a search: 31 samples,
    52 searches, ~4 s CPU, where binding (no bonus) takes 3 samples and 8 searches. A
    rule on the failure's inputs instead (no bonus when it rejected fewer than two sampled
    values, local repair's rule) made kitchen_fluent's plans longer (placements rejected
    against the kettle's slot, which other slots fix): seeds 0-9, 104 -> 107 searches,
    36 instead of 32 actions on 4 seeds (docs/results/planner/issue19.md)."""

    cheap: bool = True


@dataclass(frozen=True)
class Skeleton:
    stream_plan: tuple[InstanceKey, ...]
    placeholders: dict[InstanceKey, tuple[str, ...]]
    actions: tuple[str, ...]  # the optimistic plan, for diagnostics
    contexts: dict[InstanceKey, tuple[Fact, ...]] = field(default_factory=dict)
    # The optimistic plan as (action, arguments): bound, it is the first plan to check.
    steps: tuple[tuple[str, tuple[str, ...]], ...] = ()
    # (step, output index, bound placeholders) of every generator output taken so far, so
    # that a local repair and the ordinary alternative do not extend the same branch twice.
    tried: set[tuple[object, ...]] = field(default_factory=set, compare=False)
    # Nogoods: placeholder values under which a test of this stream plan failed (see
    # :meth:`learn_nogood`); a binding that assigns all of one's values is doomed.
    nogoods: list[tuple[tuple[str, str], ...]] = field(default_factory=list, compare=False)
    # placeholder -> the instance whose output it is (filled by the first learn_nogood)
    producers: dict[str, InstanceKey] = field(default_factory=dict, compare=False)
    # Whether actions of the task it was found in have costs (see partial_guess's use).
    action_costs: bool = field(default=False, compare=False)
    # Per stream plan position, when given (a :fluents instance used in several states has
    # an entry per state, see ContextualStreamPlan): the placeholders its output binds and
    # the context it is called in; else looked up by instance in ``placeholders`` and
    # ``contexts``.
    entry_outputs: tuple[tuple[str, ...], ...] = ()
    entry_contexts: tuple[tuple[Fact, ...], ...] = ()
    retries: RetryPolicy = field(default_factory=RetryPolicy, compare=False)

    def outputs_at(self, position: int) -> tuple[str, ...]:
        """The placeholders bound by the output of stream plan entry ``position``."""
        if self.entry_outputs:
            return self.entry_outputs[position]
        return self.placeholders.get(self.stream_plan[position], ())

    def context_at(self, position: int) -> tuple[Fact, ...]:
        """The state facts (with placeholders) entry ``position`` is called under."""
        if self.entry_contexts:
            return self.entry_contexts[position]
        return self.contexts.get(self.stream_plan[position], ())

    def learn_nogood(self, step: int, mapping: dict[str, str]) -> None:
        """Record that the test at ``step`` failed with the placeholders bound by
        ``mapping``. Its inputs are placeholders (or fixed values), and each placeholder is
        an output of an earlier step whose own inputs are placeholders too: with the same
        values of that set of placeholders, every binding calls the test on the same inputs,
        which it already rejected (a test without ``:fluents`` is called once per input
        tuple). Such bindings are dropped instead of being processed to that test again
        (kitchen_fluent: alternatives of unrelated samplers re-ran a failed collision test,
        spending the sampling share before a search)."""
        producer = self.producers
        if not producer:
            producer.update((placeholder, key) for key, outputs in self.placeholders.items()
                            for placeholder in outputs)
            producer.update((placeholder, key) for position, key in enumerate(self.stream_plan)
                            for placeholder in self.outputs_at(position))
        relevant: set[str] = set()
        pending = [x for x in self.stream_plan[step][1] if x in producer]
        while pending:
            placeholder = pending.pop()
            if placeholder in relevant:
                continue
            relevant.add(placeholder)
            pending.extend(x for x in producer[placeholder][1] if x in producer)
        if not relevant <= mapping.keys():
            return  # a placeholder bound outside this stream plan: keep the binding
        nogood = tuple(sorted((x, mapping[x]) for x in relevant))
        if nogood not in self.nogoods:
            self.nogoods.append(nogood)

    def doomed(self, mapping: dict[str, str]) -> bool:
        """Whether ``mapping`` assigns every value of a recorded nogood."""
        return any(all(mapping.get(x) == value for x, value in nogood)
                   for nogood in self.nogoods)


@dataclass
class Binding:
    skeleton: Skeleton
    step: int = 0
    mapping: dict[str, str] = field(default_factory=dict)
    made_by: dict[str, tuple[StreamInstance, tuple[str, ...]]] = field(default_factory=dict)
    output_index: int = 0
    attempts: int = 0
    parent: Binding | None = None  # the binding this one extends by one step
    repairs: int = 0  # local repairs made on the path to this binding
    # Of ``attempts``, those made at steps whose retries adaptive's cheap bonus allowed
    # (see :func:`over_retry_limit`).
    cheap_attempts: int = 0
    # The step whose first call was deferred for its failing family (see advance).
    deferred: int = -1

    def branch_key(self) -> tuple[object, ...]:
        return (self.step, self.output_index, tuple(sorted(self.mapping.items())))

    def priority(self) -> tuple[int, int]:
        return (self.attempts, -self.step)


class BindingQueue:
    def __init__(self) -> None:
        self._heap: list[tuple[tuple[int, int], int, Binding]] = []
        self._counter = itertools.count()

    def push(self, binding: Binding) -> None:
        heapq.heappush(self._heap, (binding.priority(), next(self._counter), binding))

    def pop(self) -> Binding:
        self._drop_doomed()
        return heapq.heappop(self._heap)[2]

    def peek(self) -> Binding | None:
        self._drop_doomed()
        return self._heap[0][2] if self._heap else None

    def __len__(self) -> int:
        self._drop_doomed()
        return len(self._heap)

    def _drop_doomed(self) -> None:
        """Discard head bindings that a nogood of their skeleton dooms (they would only
        reach a test that already failed on the same inputs)."""
        heap = self._heap
        while heap and heap[0][2].skeleton.doomed(heap[0][2].mapping):
            heapq.heappop(heap)


def advance(state: PlannerState, binding: Binding) -> list[Binding] | None:
    """Process one step of ``binding``: the bindings to queue, or ``None`` when complete."""
    plan = binding.skeleton.stream_plan
    if binding.step >= len(plan):
        return None
    name, inputs = plan[binding.step]
    real_inputs = tuple(binding.mapping.get(x, x) for x in inputs)
    if any(x.startswith("#") for x in real_inputs):
        return []
    context = bind_context(binding.skeleton.context_at(binding.step), binding.mapping)
    if context is None:
        return []
    instance = state.instance(name, real_inputs, context)
    if instance.is_test:
        if instance.num_calls == 0:
            state.call(instance)
        if isinstance(instance.external, StreamFunction) or instance.value:
            return [Binding(binding.skeleton, binding.step + 1, binding.mapping,
                            binding.made_by, 0, binding.attempts, binding, binding.repairs,
                            binding.cheap_attempts)]
        state.record_failure(instance)
        report_unusable(state, real_inputs, binding.made_by)
        record_rejection(state, real_inputs, binding.made_by)
        if (PARK_REJECTED_SAMPLES and not state_dependent(instance)
                and not _against_given_value(state, real_inputs, binding.made_by)):
            rejected = latest_sample(real_inputs, binding.made_by, state.objects.ranks,
                                     state.problem.objects)
            if rejected is not None:
                state.parked.park(rejected)
        binding.skeleton.retries.cheap = not state_dependent(instance)
        if not context:
            binding.skeleton.learn_nogood(binding.step, binding.mapping)
        return _local_repair(state, binding, real_inputs)
    key = binding.branch_key()
    if key in binding.skeleton.tried:
        return []  # a local repair or an ordinary alternative took this branch already
    if instance.num_calls == 0 and binding.deferred != binding.step:
        penalty = state.families.instance_penalty(name, real_inputs, state.problem.objects)
        if penalty:
            # A family that keeps failing (see .families): its first call waits as many
            # retries as the optimistic evaluation adds levels, once per step.
            binding.deferred = binding.step
            binding.attempts += penalty
            return [binding]
    if binding.output_index >= len(instance.results) and not instance.exhausted:
        state.call(instance)
    if binding.output_index < len(instance.results):
        binding.skeleton.tried.add(key)
        output = instance.results[binding.output_index]
        placeholders = binding.skeleton.outputs_at(binding.step)
        mapping = {**binding.mapping, **dict(zip(placeholders, output, strict=True))}
        made_by = {**binding.made_by, **{o: (instance, output) for o in output}}
        child = Binding(binding.skeleton, binding.step + 1, mapping, made_by, 0,
                        binding.attempts, binding, binding.repairs, binding.cheap_attempts)
        alternative = Binding(binding.skeleton, binding.step, binding.mapping,
                              binding.made_by, binding.output_index + 1, binding.attempts + 1,
                              binding.parent, binding.repairs, binding.cheap_attempts)
        return [child, alternative]
    if instance.exhausted:
        state.record_failure(instance)
        report_unusable(state, real_inputs, binding.made_by)
        binding.skeleton.retries.cheap = not state_dependent(instance)
        if SIBLING_PROBE_OUTPUTS:
            probe_siblings(state, binding)
        if (CONTEXT_SIBLING_PROBE_CALLS and state_dependent(instance)
                and not instance.results):
            probe_context_siblings(state, instance)
        return []
    binding.attempts += 1  # nothing this call: retry later
    return [binding]


# When a cheap generator of a stream plan runs out of outputs that its tests accept, its
# siblings in the same stream plan (instances of the same stream never called, over real
# inputs that differ from its own in one value) are tried at once with the stream plan's
# tests on their outputs, up to this many outputs each (0: off); see probe_siblings.
SIBLING_PROBE_OUTPUTS = 4

# When a test on a binding's path rejects values, the one the binding sampled last is
# parked: kept out of optimistic tasks and eager calls until a full search fails (see
# :mod:`.parking`). False: every sample enters every later task.
PARK_REJECTED_SAMPLES = True


def probe_siblings(state: PlannerState, failed: Binding) -> None:
    """Learn several conflicts from one failed stream plan (PDDLStream learns them one
    search at a time): after the cheap generator at ``failed``'s step ran out of outputs,
    each *sibling* in its stream plan, an instance of the same stream over real inputs that
    differ from the exhausted one's in at most one value and that was never called, is
    called and its outputs checked by the stream plan's tests that take that output and
    otherwise real values, until an output passes them, the instance runs out, or
    :data:`SIBLING_PROBE_OUTPUTS` outputs were tried. A sibling that runs out gets no
    placeholder in the next optimistic evaluation, and its outputs and test results are
    real facts either way.

    kitchen_fluent: the coaster has one slot, where the saucer stands. A plan that parks
    the pitcher, the saucer and the spoon on "fresh" coaster poses failed at the pitcher's
    (its sampler's only slot collides), and each of the two others cost one more search
    and skeleton (seeds 0-9 adaptive: 96 -> 84 searches, binding 107 -> 94, plans
    unchanged; docs/results/planner/issue19.md). Only siblings: probing every generator of
    the failed plan, or every one with real inputs, raised the searches of the seeds that
    needed 7 to 8-9 (the probed table samplers' higher complexity sent the next search to
    other untried samplers)."""
    skeleton = failed.skeleton
    plan = skeleton.stream_plan
    name = plan[failed.step][0]
    external = state.externals[name]
    if (not isinstance(external, Stream) or external.fluents
            or not observed_cheap(state.history.get(name), state.stream_stats.get(name))):
        return
    failed_inputs = tuple(failed.mapping.get(x, x) for x in plan[failed.step][1])
    for position, (other, inputs) in enumerate(plan):
        if other != name or position == failed.step:
            continue
        real_inputs = tuple(failed.mapping.get(x, x) for x in inputs)
        if any(x.startswith("#") for x in real_inputs) or sum(
                a != b for a, b in zip(real_inputs, failed_inputs, strict=True)) > 1:
            continue
        instance = state.instance(name, real_inputs)
        if instance.num_calls or instance.exhausted:
            continue
        # Only within its domain: a domain fact certified by a later entry of the plan
        # is not real yet.
        if not _domain_real(state, name, real_inputs):
            continue
        outputs = skeleton.outputs_at(position)
        # The tests see the failed binding's values and the sibling's own outputs.
        bound = {x: v for x, v in failed.mapping.items() if x not in outputs}
        tests = []
        for test_position, (test, test_inputs) in enumerate(plan):
            test_external = state.externals[test]
            if (test_position == position or isinstance(test_external, StreamFunction)
                    or (isinstance(test_external, Stream) and (not test_external.is_test
                                                               or test_external.fluents))
                    or not set(test_inputs) & set(outputs)):
                continue
            resolved = tuple(bound.get(x, x) for x in test_inputs)
            if all(x in outputs or not x.startswith("#") for x in resolved):
                tests.append((test, resolved))
        _probe(state, instance, outputs, tests, SIBLING_PROBE_OUTPUTS,
               real_test_domains=False)


# After a cheap :fluents generator produced nothing in a state, this many of its never-called
# siblings are called in the same state (0: off); see probe_context_siblings.
CONTEXT_SIBLING_PROBE_CALLS = 64


def probe_context_siblings(state: PlannerState, failed: StreamInstance) -> None:
    """After the ``:fluents`` generator instance ``failed`` produced nothing in its
    context (the state's fluent facts), call its never-called *siblings* in that same
    context, up to :data:`CONTEXT_SIBLING_PROBE_CALLS`: instances of the same stream over
    real inputs that differ from its own in one value (a motion from another configuration
    to the same goal, or from the same start to another goal). Only for a stream observed
    cheap (:func:`.effort.observed_cheap`). Each sibling that produces nothing is recorded as
    failed in that context (``failed_contexts``), so no search plans with it there; one that
    succeeds adds a real output, valid in that context only.

    A failed :fluents instance blocks only itself, and the search's next plan in the same
    state is usually its sibling (kitchen_fluent seed 20, the pitcher carried past a tall
    object: the motion to the mug's configuration failed from 5 starts in turn, one
    search each; 20 searches, 2.1 s CPU, with the probe 10, 0.6 s)."""
    name = failed.name
    if not observed_cheap(state.history.get(name), state.stream_stats.get(name)):
        return
    context = failed.fluent_facts
    calls = 0
    for inputs in list(state.open_real_bindings(state.externals[name])):
        if calls >= CONTEXT_SIBLING_PROBE_CALLS:
            break
        if sum(a != b for a, b in zip(inputs, failed.inputs, strict=True)) != 1:
            continue
        sibling = state.instance(name, inputs, context)
        if sibling.num_calls or sibling.exhausted:
            continue
        state.call(sibling)
        calls += 1
        if sibling.exhausted and not sibling.results:
            state.record_failure(sibling)


# When a plan's shared placeholders are refined (the search runs again), the plan's cheap
# generators over real inputs are first tried with the plan's tests, up to this many
# outputs each (0: off); see probe_refined_plan.
REFINEMENT_PROBE_OUTPUTS = 4


# A speculative search (adaptive) leaves out the never-called generator instances whose
# sibling failed (:func:`.optimistic.failed_siblings`); see solve_with_skeletons.
HOLD_BACK_FAILED_SIBLINGS = True


def probe_refined_plan(state: PlannerState, evaluation: OptimisticEvaluation,
                       needed: set[Fact], refined: set[InstanceKey]) -> None:
    """Before the search that follows a refinement: each generator of the refined plan's
    stream plan whose inputs are real and whose outputs are its own (not shared), never
    called, without ``:fluents`` and observed cheap (or not measured yet: its first call
    measures it, and a call found costly ends its probe), is called and its outputs checked
    by the stream plan's tests (cheap or unmeasured too) that take them and otherwise real
    values, until one passes, it runs out, or :data:`REFINEMENT_PROBE_OUTPUTS` were tried.

    The refined task differs from the one searched only in the refined instances'
    placeholders, so its search usually plans with the same unshared instances again, and
    the queue would call them first thing; their failures then cost that search.
    kitchen_fluent: the first plan serves the mug on a fresh coaster pose from shared
    configurations; the coaster's one slot holds the saucer, so the refined plan's stream
    plan died on it and a third plan (move the saucer first) was searched every seed.
    A probe certifies real facts only and marks a generator exhausted only when it ran out,
    so the next search stays sound; the calls are cheap ones the plan asked for.

    Only generators that some such test checks (a probe with nothing to check learns little
    and still makes real values), and not when a ``refined`` instance's stream has an
    explicit sharing policy (``StreamInfo(opt_gen_fn=PartialInputs(...))``): the refined
    instances take the probed outputs as inputs, and once those are real values they are
    other instances, which such a policy makes share again (one more refinement and
    search); by default instances over real values keep their own outputs."""
    if any(state.bindings[name].info.opt_gen_fn is not None for name, _ in refined):
        return
    plan = stream_plan(state, evaluation, needed)
    for key in plan:
        name, inputs = key
        external = state.externals[name]
        if (not isinstance(external, Stream) or external.is_test or external.fluents
                or any(x.startswith("#") for x in inputs)):
            continue
        outputs = evaluation.outputs.get(key, ())
        if not outputs or outputs in evaluation.sharing:
            continue
        if not _cheap_or_unmeasured(state, name):
            continue
        instance = state.instance(name, inputs)
        if instance.num_calls or instance.exhausted:
            continue
        tests = []
        for test, test_inputs in plan:
            test_external = state.externals[test]
            if (isinstance(test_external, Stream) and test_external.is_test
                    and not test_external.fluents and set(test_inputs) & set(outputs)
                    and all(x in outputs or not x.startswith("#") for x in test_inputs)
                    and _cheap_or_unmeasured(state, test)):
                tests.append((test, test_inputs))
        if tests:
            _probe(state, instance, outputs, tests, REFINEMENT_PROBE_OUTPUTS)


def _cheap_or_unmeasured(state: PlannerState, name: str) -> bool:
    """Whether stream ``name`` was observed cheap (:func:`.effort.observed_cheap`) or
    has no observed call yet (this run or the history): one call then measures it."""
    stats = state.stream_stats.get(name)
    if not (stats is not None and stats.calls) and not state.history.get(name, {}).get("calls"):
        return True
    return observed_cheap(state.history.get(name), stats)


def _probe(state: PlannerState, instance: StreamInstance, outputs: tuple[str, ...],
           tests: list[tuple[str, tuple[str, ...]]], limit: int, *,
           real_test_domains: bool = True) -> None:
    """Call the generator ``instance`` until an output (bound to the placeholders
    ``outputs``) passes every one of ``tests`` (stream name, inputs over those placeholders
    and real values), it runs out, it is found costly after a call
    (:func:`.effort.observed_cheap`), or ``limit`` outputs were tried. A run-out instance
    is recorded as failed.

    With ``real_test_domains`` a test whose domain facts are not all real is skipped (the
    refined plan's tests: a later entry of the plan may certify them); without it every
    test is called (the sibling probe's tests come from a stream plan that bound them).
    The sibling probe enters only with a generator observed cheap, so the costly stop
    does not change it in practice."""
    for index in range(limit):
        if index >= len(instance.results):
            if instance.exhausted or (instance.num_calls and not observed_cheap(
                    state.history.get(instance.name), state.stream_stats.get(instance.name))):
                break
            state.call(instance)
            if index >= len(instance.results):
                break
        bound = dict(zip(outputs, instance.results[index], strict=True))
        accepted = True
        for test, test_inputs in tests:
            inputs = tuple(bound.get(x, x) for x in test_inputs)
            if real_test_domains and not _domain_real(state, test, inputs):
                continue
            checked = state.instance(test, inputs)
            if checked.num_calls == 0:
                state.call(checked)
            if not checked.value:
                accepted = False
                if all(x in bound.values() or x in state.problem.objects for x in inputs):
                    # rejected against the problem's own values (see record_rejection)
                    state.rejected_outputs.setdefault(
                        (instance.name, instance.inputs), set()).add(instance.results[index])
                break
        if accepted:
            break
    if instance.exhausted:
        state.record_failure(instance)


def _domain_real(state: PlannerState, name: str, inputs: tuple[str, ...]) -> bool:
    """Whether every domain fact of external ``name`` over real ``inputs`` is known."""
    external = state.externals[name]
    domain = instantiate_atoms(external_domain(external),
                               dict(zip(external_inputs(external), inputs, strict=True)))
    return all(fact in state.facts.members for fact in domain)


def _against_given_value(state: PlannerState, consumed: tuple[str, ...],
                         made_by: dict[str, tuple[StreamInstance, tuple[str, ...]]]) -> bool:
    """Whether a test rejected ``consumed`` against a value the problem gave (an initial
    pose: a problem object with a value other than its name). Such a sample is kept in
    later tasks: the value in its way may move (a block standing in the goal region), and a
    plan that moves it first can use the sample."""
    objects = state.problem.objects
    return any(x not in made_by and x in objects and state.objects.value(x) != x
               for x in consumed)


def state_dependent(instance: StreamInstance) -> bool:
    """Whether ``instance``'s stream declares ``:fluents``: its failure is one in the state
    it was called in (a route blocked by debris, a motion blocked by the objects standing
    where they stand), which new samples upstream rarely fix and another plan (clear the
    debris first, move the object) does."""
    external = instance.external
    return isinstance(external, Stream) and bool(external.fluents)


def _local_repair(state: PlannerState, failed: Binding, consumed: tuple[str, ...]
                  ) -> list[Binding]:
    """After a test of ``failed`` rejected ``consumed``: the binding that takes the next
    output of the generator step that sampled the latest of those values, at the same
    priority (``[]`` when the repair budget is spent or that generator is not cheap)."""
    if failed.repairs >= MAX_LOCAL_REPAIRS:
        return []
    producers = sampled_inputs(state, consumed, failed.made_by)
    if not producers:
        return []
    plan = failed.skeleton.stream_plan
    ancestor = failed.parent
    while ancestor is not None:
        name, inputs = plan[ancestor.step]
        real_inputs = tuple(ancestor.mapping.get(x, x) for x in inputs)
        producer = next((p for p in producers
                         if p.name == name and p.inputs == real_inputs), None)
        if producer is not None:
            if not repairable(state, producer, ancestor.output_index + 1):
                return []
            return [Binding(failed.skeleton, ancestor.step, ancestor.mapping,
                            ancestor.made_by, ancestor.output_index + 1, ancestor.attempts,
                            ancestor.parent, failed.repairs + 1, ancestor.cheap_attempts)]
        ancestor = ancestor.parent
    return []


def solve_with_skeletons(state: PlannerState, adaptive: bool,
                         member: InterleavedIncremental | None = None) -> PlanResult:
    """Adaptive (``adaptive``) or binding, interleaved with the incremental algorithm once
    a grace period passed without a plan (:mod:`.interleave`): with ``member`` (the
    caller's, to run it on after an unproven "infeasible"), else with a member made here
    when one applies."""
    member = member or interleaved_incremental(state)
    result = _solve_with_skeletons(state, adaptive, member)
    return result if member is None else member.annotate(result)


def _solve_with_skeletons(state: PlannerState, adaptive: bool,
                          member: InterleavedIncremental | None) -> PlanResult:
    complexity = state.config.initial_complexity
    placeholders = Placeholders()
    queue = BindingQueue()
    seen_skeletons: set[tuple[object, ...]] = set()
    last_search_work = 0
    # Whether an optimistic task so far had an action with a cost (see
    # STEPS_PER_EVALUATION_WITHOUT_COSTS).
    action_costs = False
    retry_threshold = 0
    facts_at_search = -1
    solved_expansions = 0  # the most expansions a solved optimistic search needed
    capped_task: frozenset[object] | None = None
    sampling = SamplingRound()
    speculative_in_a_row = 0
    # After a plan whose shared placeholders were refined: whether the search that found it
    # was a full one (the next iteration searches again, as that one would have).
    refining: bool | None = None
    refined_expansions = 0  # expansions of the search whose plan was refined
    try:
        while not state.timed_out():
            if member is not None and (settled := member.run()) is not None:
                return settled
            state.iterations += 1
            evaluate_eager(state, complexity)
            head = queue.peek()
            stalled = (head is None
                       or over_retry_limit(state, head, retry_threshold, adaptive)
                       or speculative_in_a_row >= MAX_SPECULATIVE_IN_A_ROW
                       or refining is True)
            learned = len(state.facts.members) != facts_at_search
            # A speculative search only after a stream plan met a failure since the last
            # search: while the queue's bindings progress, their skeleton is on track, and a
            # search of the larger task would mostly find it again (kitchen_fluent: five
            # optimistic searches of ~1,500 actions, each as costly as the whole sampling).
            if stalled or refining is not None or (adaptive and learned
                                                    and sampling.failures):
                # Adaptive also searches when sampling taught it new facts although the
                # queue could go on: a speculative search, bounded by a few times what the
                # last successful one needed and never raising the budget, the complexity
                # or the retry bound. With samplers that know nothing of each other
                # (tamp2d_uniform_tight_4 seed 2) most such tasks have no plan until the
                # queue has sampled more, and a search that fails explores everything
                # within its budget: 600, then 1,200 expansions (2 s) each time.
                speculative = not stalled
                # The full search that follows a refinement is bounded by what the refined
                # search needed (see REFINED_SEARCH_FACTOR).
                after_refinement = refining is True and REFINED_SEARCH_FACTOR > 0
                refining = None
                speculative_in_a_row = speculative_in_a_row + 1 if speculative else 0
                facts_at_search = len(state.facts.members)
                sampling.failures = 0
                # A speculative search leaves out the never-called siblings of generators
                # that failed (see HOLD_BACK_FAILED_SIBLINGS); a full search sees them.
                evaluation = optimistic_evaluation(
                    state, complexity, placeholders,
                    failed_siblings(state) if speculative and HOLD_BACK_FAILED_SIBLINGS
                    else None)
                state.parked.note_task(len(evaluation.index.members))
                # The most advanced binding's plan, with what it bound so far, is checked
                # first: once sampling made its facts real it is usually still a plan.
                # Rebased onto this task (partial_guess) only without action costs: with
                # them, a search over the values sampled since may find a cheaper plan than
                # the old skeleton's (tamp2d_uniform, rebased: 7 of 80 seeds costlier, none
                # cheaper; blocked_8 seed 5 170.5 instead of 117.8).
                guess = None if head is None else (
                    bound_plan(head.skeleton.steps, head.mapping)
                    if head.skeleton.action_costs else partial_guess(state, head, evaluation))
                # A task that grounds as the last one whose search ran out of budget is
                # not searched again (kitchen_symbolic seed 6: three searches of the same
                # real task with 600, 1,200 and 2,400 expansions while the complexity
                # grew): the complexity grows until it changes, up to the bound.
                skip = (capped_task if complexity < state.config.max_complexity
                        + state.max_object_level() else None)
                limit = (min(state.search_budget, max(
                    SPECULATIVE_MIN_EXPANSIONS, SPECULATIVE_FACTOR * solved_expansions))
                    if speculative else min(state.search_budget, max(
                        SPECULATIVE_MIN_EXPANSIONS, REFINED_SEARCH_FACTOR * refined_expansions))
                    if after_refinement else None)
                discrete = state.search(evaluation.index.members, evaluation.object_types,
                                        evaluation.function_values, limit,
                                        context_blocks=evaluation.context_blocks,
                                        budgeted=not speculative and not after_refinement,
                                        guess=guess, skip_if_grounded_as=skip)
                if discrete.solved and discrete.outcome is not None:
                    solved_expansions = max(solved_expansions, discrete.outcome.expanded)
                if discrete.capped and not discrete.skipped:
                    capped_task = grounding_signature(discrete.grounding)
                elif not discrete.capped:
                    capped_task = None
                # Both asked once per task: costs with a nonzero value (partial guesses)
                # and costs of any kind, even a function valued 0 (the sampling share).
                task_costs = any(action.cost for action in discrete.grounding.actions)
                action_costs = action_costs or task_costs or any(
                    action.cost_terms for action in discrete.grounding.actions)
                if not discrete.skipped and (discrete.outcome is None
                                             or not discrete.outcome.guessed):
                    # A followed guess did no search work: keep the previous sampling share.
                    last_search_work = discrete.outcome.evaluated if discrete.outcome else 0
                if speculative and not discrete.solved:
                    # Nothing learned about the bounds: go on with the queue, for a share
                    # of work that grows with what this search cost.
                    steps = sampling_share(last_search_work, action_costs)
                    result = _process(state, queue, adaptive, steps, retry_threshold, sampling)
                    if result is not None:
                        return result
                    continue
                state.diagnose(discrete, evaluation.index.members)
                if discrete.solved:
                    facts, terms = plan_preimage(discrete)
                    unique_before = set(placeholders.unique)
                    found = bindable_stream_plan(state, evaluation, facts | terms,
                                                 placeholders)
                    if found is None:
                        refining = not speculative  # shared placeholders refined
                        if REFINEMENT_PROBE_OUTPUTS:
                            probe_refined_plan(state, evaluation, facts | terms,
                                               set(placeholders.unique) - unique_before)
                        refined_expansions = max(
                            discrete.outcome.expanded if discrete.outcome else 0,
                            solved_expansions if discrete.outcome is None
                            or discrete.outcome.guessed else 0)
                        continue
                    plan = tuple(found)
                    if not plan and state.parked:
                        # The task left parked samples out: a plan over real facts only is
                        # checked over all of them (a derived condition such as "no block
                        # in the way" may hold only because a fact was left out).
                        real = state.search(state.facts.members, state.object_types,
                                            state.function_values, REAL_SEARCH_EXPANSIONS,
                                            guess=[(a.name, a.args)
                                                   for a in discrete.actions or ()])
                        if real.solved:
                            facts, terms = plan_preimage(real)
                            return state.result(SOLVED, real, facts | terms)
                        state.parked.release(state.deferred_eager)
                        continue
                    if not plan:
                        return state.result(SOLVED, discrete, facts | terms)
                    state.remember_skeleton([str(a) for a in discrete.actions or []])
                    entries = contextual_stream_plan(state, evaluation, plan, discrete)
                    signature = (entries.entries, entries.outputs, entries.contexts)
                    if signature not in seen_skeletons:
                        seen_skeletons.add(signature)
                        queue.push(Binding(Skeleton(
                            entries.entries, {},
                            tuple(str(a) for a in discrete.actions or []),
                            steps=entries.steps, action_costs=task_costs,
                            entry_outputs=entries.outputs,
                            entry_contexts=entries.contexts)))
                    elif stalled:
                        # Nothing new to try at this bound: allow more retries and
                        # more complex optimistic values.
                        retry_threshold += 1
                        complexity += 1
                else:
                    if not evaluation.cut and not len(queue) and not discrete.capped:
                        return state.result(INFEASIBLE, None)
                    if state.parked and not discrete.capped:
                        # A full search proved that no plan uses the samples it saw: search
                        # again at the same bound over every sample (and their eager calls).
                        # One that ran out of expansions keeps them parked: its budget has
                        # doubled, and a later exhaustive failure releases them.
                        state.parked.release(state.deferred_eager)
                        continue
                    retry_threshold += 1
                    complexity += 1
                    if (complexity > state.config.max_complexity + state.max_object_level()
                            and not len(queue) and not discrete.capped
                            and not within_limit(state, evaluation)):
                        return state.result(INFEASIBLE, None)
            steps = sampling_share(last_search_work, action_costs)
            if adaptive and stalled and len(seen_skeletons) >= 2 and steps == 1:
                result = _process_within_bound(state, queue, retry_threshold, sampling)
                if result is not None:
                    return result
            result = _process(state, queue, adaptive, steps, retry_threshold, sampling)
            if result is not None:
                return result
        return state.result(TIMEOUT, None)
    except SearchTimeout:
        return state.result(TIMEOUT, None)


def sampling_share(evaluated: int, action_costs: bool) -> int:
    """Binding steps to process after a search that evaluated ``evaluated`` states (at
    least one): :data:`STEPS_PER_EVALUATION` per state, or
    :data:`STEPS_PER_EVALUATION_WITHOUT_COSTS` while no optimistic task had action costs."""
    rate = STEPS_PER_EVALUATION if action_costs else STEPS_PER_EVALUATION_WITHOUT_COSTS
    return max(1, round(evaluated * rate))


def partial_guess(state: PlannerState, binding: Binding, evaluation: OptimisticEvaluation
                  ) -> list[tuple[str, tuple[str, ...]]]:
    """The optimistic plan of ``binding``'s skeleton as a plan of the task of ``evaluation``:
    placeholders bound so far replaced by their values, and the outputs of instances not yet
    called replaced by the placeholders that ``evaluation`` gives the same instance over the
    values bound so far, or, when another binding called that instance already, by its first
    output (the one this binding takes first). Without the second part a half-bound plan is
    rarely one of the new task: an instance whose inputs got bound is a different instance
    there, with its own output placeholders (kitchen_fluent seed 0: every speculative
    search's guess failed on ``move @q8 #t447 #q122``, a motion to the kinematics of a
    sampled pose, and searched in full). Follows the stream plan in order, so a rebased
    output feeds the later instances."""
    skeleton = binding.skeleton
    mapping = dict(binding.mapping)
    for position in range(binding.step, len(skeleton.stream_plan)):
        name, inputs = skeleton.stream_plan[position]
        old = skeleton.outputs_at(position)
        if not old or all(x in mapping for x in old):
            continue
        key = (name, tuple(mapping.get(x, x) for x in inputs))
        new = evaluation.outputs.get(key)
        called = state.instances.get(key)
        if new is None and called is not None and called.results:
            new = called.results[0]
        if new is not None and len(new) == len(old):
            for placeholder, renamed in zip(old, new, strict=True):
                mapping.setdefault(placeholder, renamed)
    return bound_plan(skeleton.steps, mapping)


def cheap_step(state: PlannerState, binding: Binding) -> bool:
    """Whether processing ``binding`` next calls a stream whose observed calls are cheap
    (:func:`.effort.observed_cheap`, CPU time; a finished binding's check is not)."""
    plan = binding.skeleton.stream_plan
    if binding.step >= len(plan):
        return False
    name = plan[binding.step][0]
    return observed_cheap(state.history.get(name), state.stream_stats.get(name))


def _new_output(state: PlannerState, binding: Binding) -> bool:
    """Whether processing ``binding`` asks a generator for an output it has not made yet: a
    new object, whose consequences (eager streams over it, a larger task to ground) cost
    more than the call."""
    plan = binding.skeleton.stream_plan
    name, inputs = plan[binding.step]
    external = state.externals[name]
    if not isinstance(external, Stream) or external.is_test:
        return False
    key = (name, tuple(binding.mapping.get(x, x) for x in inputs))
    instance = state.instances.get(key)
    return instance is None or binding.output_index >= len(instance.results)


def retry_limit(state: PlannerState, binding: Binding, retry_threshold: int,
                adaptive: bool) -> int:
    """The most retries (alternative outputs, empty calls) ``binding`` may have made and
    still be processed before the next search: ``retry_threshold``, or with adaptive
    :data:`CHEAP_RETRY_FACTOR` times as many when its next call is cheap."""
    if adaptive and binding.skeleton.retries.cheap and cheap_step(state, binding):
        return (retry_threshold + 1) * CHEAP_RETRY_FACTOR
    return retry_threshold


def over_retry_limit(state: PlannerState, binding: Binding, retry_threshold: int,
                     adaptive: bool) -> bool:
    """Whether ``binding`` made more retries than :func:`retry_limit` allows before the
    next search. At a step without the cheap bonus, retries that the bonus allowed at
    earlier steps (``cheap_attempts``) do not count: they are no evidence against this
    step, and such a binding, stalled by them at its first costly step, made adaptive
    search again only to follow its plan as the guess, a skeleton of its remaining
    stream plan with fresh counts (kitchen_fluent: a stall at the first motion after ~5
    placement retries on 10 of 30 seeds, ~35 ms each). Only for skeletons of tasks without
    action costs (as :func:`partial_guess`): with costs, the search at such a stall finds
    cheaper plans over what was sampled since (tamp2d_uniform_tight_8 seeds 0 and 6 with
    the rule: cost 121 -> 135 and 122 -> 152)."""
    limit = retry_limit(state, binding, retry_threshold, adaptive)
    if limit != retry_threshold or binding.skeleton.action_costs:
        return binding.attempts > limit
    return binding.attempts - binding.cheap_attempts > limit


@dataclass
class SamplingRound:
    """What processing the queue met since the last search."""

    failures: int = 0  # binding steps that failed (a test, an exhausted or empty stream)


def _process_within_bound(state: PlannerState, queue: BindingQueue, retry_threshold: int,
                          sampling: SamplingRound) -> PlanResult | None:
    """Adaptive, after a full search: process bindings within the retry bound, as
    ``binding`` does (PDDLStream's process_complexity), while the CPU time of all stream
    calls so far is below :data:`SEARCH_SAMPLE_RATIO` times that of all searches so far
    (PDDLStream's ``search_sample_ratio``)."""
    while len(queue) and not state.timed_out():
        head = queue.peek()
        assert head is not None
        if head.attempts > retry_threshold or (
                state.sampling_cpu() >= SEARCH_SAMPLE_RATIO * state.search_cpu):
            return None
        result = _process_one(state, queue, queue.pop(), sampling, adaptive=True)
        if result is not None:
            return result
    return None


def _process(state: PlannerState, queue: BindingQueue, adaptive: bool, steps: int,
             retry_threshold: int, sampling: SamplingRound) -> PlanResult | None:
    done = 0.0
    while len(queue) and not state.timed_out():
        head = queue.peek()
        assert head is not None
        if adaptive and done >= steps:
            return None
        cheap = adaptive and cheap_step(state, head) and not _new_output(state, head)
        done += CHEAP_STEP_COST if cheap else 1.0
        if over_retry_limit(state, head, retry_threshold, adaptive):
            return None
        result = _process_one(state, queue, queue.pop(), sampling, adaptive)
        if result is not None:
            return result
    return None


def _process_one(state: PlannerState, queue: BindingQueue, binding: Binding,
                 sampling: SamplingRound, adaptive: bool) -> PlanResult | None:
    """Advance ``binding`` one step and queue what follows; a complete binding's plan is
    checked over the real facts (the result when it is a plan)."""
    # Whether a retry made at this step is one the cheap bonus allowed (see
    # over_retry_limit): the alternative output, or the same binding after an empty call.
    cheap_retry = (adaptive and SEPARATE_CHEAP_RETRIES and not binding.skeleton.action_costs
                   and binding.skeleton.retries.cheap and cheap_step(state, binding))
    attempts, step = binding.attempts, binding.step
    children = advance(state, binding)
    if cheap_retry and children:
        for child in children:
            if child.step == step and child.attempts == attempts + 1:
                child.cheap_attempts += 1
    if children is not None and (not children
                                 or (len(children) == 1 and children[0] is binding)):
        sampling.failures += 1  # a dead end, or nothing this call (a local repair and
        # an ordinary output go on)
    if children is None:
        real = state.search(state.facts.members, state.object_types,
                            state.function_values, REAL_SEARCH_EXPANSIONS,
                            guess=bound_plan(binding.skeleton.steps, binding.mapping))
        if real.solved:
            facts, terms = plan_preimage(real)
            return state.result(SOLVED, real, facts | terms)
        return None
    for child in children:
        queue.push(child)
    return None
