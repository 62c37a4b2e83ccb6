"""Optimistic evaluation of streams, shared by the focused, binding and adaptive algorithms.

Instances not yet (fully) called certify their facts with placeholder objects ``#name`` up to
a complexity bound (complexity of an instance = summed complexity of its inputs + calls
made); a plan over real and optimistic facts is then retraced to the *stream plan* of
instances whose calls would make its optimistic facts real.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from ltamp_cli.planner.algorithms.common import (
    PlannerState,
    external_inputs,
    instantiate_atoms,
)
from ltamp_cli.planner.algorithms.effort import observed_cheap, order_by_effort
from ltamp_cli.planner.pddl.syntax import (
    OBJECT_TYPE,
    ExternalPredicate,
    Stream,
    StreamFunction,
)
from ltamp_cli.planner.search.clock import check_deadline
from ltamp_cli.planner.search.ground import Context, CostBound, Fact, FactIndex
from ltamp_cli.planner.search.solve import DiscreteResult
from ltamp_cli.planner.streams import StreamInstance

InstanceKey = tuple[str, tuple[str, ...]]

# Local repair: when a test of a stream plan fails on two (or more) values that streams
# sampled, the cheap generator that sampled the later one for this stream plan is asked for
# its next value and the test is repeated, at most this many times per stream plan (binding
# path), before the failure sends the algorithm back to search. In tamp2d_4blocks most failed
# stream plans are a collision between two independently sampled poses, which another sample
# of the later pose usually fixes. A test that rejects one sampled value against a value of
# the problem (a pose colliding with an obstacle that stays put) is not repaired: the
# optimistic plan is often wrong then (the obstacle has to move), and on Kitchen3D
# pour_blocked such repairs only added placements and searches. Expensive (e.g. learned)
# samplers are never repaired.
MAX_LOCAL_REPAIRS = 3


@dataclass
class OptimisticEvaluation:
    """Real facts plus optimistic ones, and which (possibly optimistic) instance made each."""

    index: FactIndex
    function_values: dict[Fact, float]
    object_types: dict[str, str]
    level: dict[str, int] = field(default_factory=dict)  # optimistic object -> complexity
    fact_producer: dict[Fact, InstanceKey] = field(default_factory=dict)
    object_producer: dict[str, InstanceKey] = field(default_factory=dict)
    outputs: dict[InstanceKey, tuple[str, ...]] = field(default_factory=dict)
    cut: bool = False  # an instance was left out by the complexity bound
    # Optimistic facts of :fluents streams -> contexts where the stream already failed.
    context_blocks: dict[Fact, list[Context]] = field(default_factory=dict)


def optimistic_evaluation(state: PlannerState, complexity: int,
                          placeholders: dict[InstanceKey, tuple[str, ...]]
                          ) -> OptimisticEvaluation:
    index = FactIndex()
    for fact in sorted(state.facts.members):  # a hash-independent order
        index.add(fact)
    evaluation = OptimisticEvaluation(index, dict(state.function_values),
                                      dict(state.object_types))
    done: set[InstanceKey] = set()
    levels = evaluation.level
    real_levels = state.object_level
    # Semi-naive fixpoint: the first round takes the inputs over real facts (enumerated
    # incrementally across evaluations), each later round only joins the facts the previous
    # round added. An instance cut by the bound stays cut (its level depends only on its
    # inputs), so it is not retried.
    since: dict[str, int] | None = None
    while True:
        before = index.sizes()
        for external in state.externals.values():
            check_deadline(state.deadline)
            if since is None:
                candidates = state.open_real_bindings(external)
            else:
                # Bindings whose inputs alone exceed the bound are not even enumerated: an
                # instance's level is at least its inputs' summed levels, so they would be
                # cut (the join still tells whether one exists, for ``cut``).
                bound = CostBound(levels, complexity)
                candidates = list(state.bindings_of(external, index, since, bound))
                if bound.exceeded:
                    evaluation.cut = True
            for inputs in candidates:
                key = (external.name, inputs)
                if key in done:
                    continue
                done.add(key)
                # Summed input complexity: values built from several placeholders cost more,
                # so low bounds favour plans over real values. Real inputs count with the
                # highest of their levels (PlannerState.object_level, PDDLStream's max).
                level = (sum([levels.get(x, 0) for x in inputs])
                         + max([real_levels.get(x, 0) for x in inputs], default=0))
                real = state.instances.get(key)
                if real is not None:
                    if real.disabled or (real.exhausted and not _pending_test(real)):
                        continue
                    level += real.num_calls
                if level > complexity:
                    evaluation.cut = True
                    continue
                _add_optimistic(state, evaluation, key, level, placeholders)
        if index.sizes() == before:
            return evaluation
        since = before


def _pending_test(instance: StreamInstance) -> bool:
    return instance.is_test and instance.num_calls == 0


def _add_optimistic(state: PlannerState, evaluation: OptimisticEvaluation, key: InstanceKey,
                    level: int, placeholders: dict[InstanceKey, tuple[str, ...]]) -> bool:
    name, inputs = key
    external = state.externals[name]
    mapping = dict(zip(external_inputs(external), inputs, strict=True))
    if isinstance(external, StreamFunction):
        term = (external.name, *(mapping[a] for a in external.head.args))
        if term not in evaluation.function_values:
            evaluation.function_values[term] = state.bindings[name].info.opt_cost
            evaluation.fact_producer[("=", *term)] = key
        return False
    outputs: tuple[str, ...] = ()
    if isinstance(external, Stream) and external.outputs:
        outputs = placeholders.get(key, ())
        if not outputs:
            number = len(placeholders)
            outputs = tuple(f"#{v[1:]}{number}" for v in external.outputs)
            placeholders[key] = outputs
        evaluation.outputs[key] = outputs
        for placeholder in outputs:
            evaluation.level[placeholder] = level + 1
            evaluation.object_types[placeholder] = OBJECT_TYPE
            evaluation.object_producer[placeholder] = key
        mapping.update(zip(external.outputs, outputs, strict=True))
        facts = instantiate_atoms(external.certified, mapping)
    elif isinstance(external, ExternalPredicate):
        facts = instantiate_atoms((external.head,), mapping)
    else:  # a test stream: what it certifies for its inputs
        facts = instantiate_atoms(external.certified, mapping)
    added = False
    failed = state.failed_contexts.get(key, [])
    for fact in facts:
        if evaluation.index.add(fact):
            evaluation.fact_producer[fact] = key
            added = True
            if failed:
                evaluation.context_blocks[fact] = failed
    return added



def stream_plan(state: PlannerState, evaluation: OptimisticEvaluation,
                needed: Iterable[Fact]) -> list[InstanceKey]:
    """Instances to call to make the needed optimistic facts real: dependencies first, and
    among independent instances the cheapest-to-fail first (:mod:`.effort`)."""
    found: list[InstanceKey] = []
    dependencies: dict[InstanceKey, set[InstanceKey]] = {}
    for fact in sorted(needed):
        if fact in state.facts.members:
            continue
        key = evaluation.fact_producer.get(fact) or evaluation.fact_producer.get(("=", *fact))
        if key is not None:
            _visit_producers(state, evaluation, key, dependencies, found)
    effort = {name: state.effort(name) for name in {key[0] for key in found}}
    return order_by_effort(found, dependencies, effort)


def _visit_producers(state: PlannerState, evaluation: OptimisticEvaluation, key: InstanceKey,
                     dependencies: dict[InstanceKey, set[InstanceKey]],
                     found: list[InstanceKey]) -> None:
    """Append ``key`` to ``found`` after the instances producing its inputs and domain facts
    (depth first), recording each instance's direct dependencies. A module-level function:
    a nested recursive one would keep the evaluation alive in a reference cycle."""
    if key in dependencies:
        return
    before: set[InstanceKey] = set()
    dependencies[key] = before
    name, inputs = key
    for value in inputs:
        producer = evaluation.object_producer.get(value)
        if producer is not None:
            _visit_producers(state, evaluation, producer, dependencies, found)
            before.add(producer)
    external = state.externals[name]
    mapping = dict(zip(external_inputs(external), inputs, strict=True))
    for fact in instantiate_atoms(external.domain, mapping):
        if fact not in state.facts.members and fact in evaluation.fact_producer:
            producer = evaluation.fact_producer[fact]
            _visit_producers(state, evaluation, producer, dependencies, found)
            before.add(producer)
    found.append(key)


def sampled_inputs(state: PlannerState, consumed: tuple[str, ...],
                   made_by: dict[str, tuple[StreamInstance, tuple[str, ...]]]
                   ) -> set[StreamInstance]:
    """The generators that sampled ``consumed`` values in this stream plan, when a local
    repair may apply: at least two of the values come from streams (this stream plan's or
    earlier ones), not from the problem. Else empty."""
    sampled = [x for x in consumed if x not in state.problem.objects]
    if len(sampled) < 2:
        return set()
    return {made_by[x][0] for x in sampled if x in made_by}


def repairable(state: PlannerState, instance: StreamInstance, used: int) -> bool:
    """Whether a local repair may ask ``instance`` for another output than its first
    ``used`` ones: it is a generator without ``:fluents`` that may have more, and its
    observed calls (this run and persisted history) were cheap (:func:`.observed_cheap`,
    in CPU time, as for automatic eager evaluation)."""
    external = instance.external
    if not isinstance(external, Stream) or external.is_test or external.fluents:
        return False
    if used >= len(instance.results) and instance.exhausted:
        return False
    return observed_cheap(state.history.get(instance.name),
                          state.stream_stats.get(instance.name))


def report_unusable(state: PlannerState, consumed: tuple[str, ...],
                     made_by: dict[str, tuple[StreamInstance, tuple[str, ...]]]) -> None:
    reported: set[int] = set()
    for name in consumed:
        if name not in made_by:
            continue
        producer, outputs = made_by[name]
        callback = producer.binding.on_unusable
        if callback is None or id(outputs) in reported:
            continue
        reported.add(id(outputs))
        inputs = tuple(state.objects.value(x) for x in producer.inputs)
        callback(inputs, tuple(state.objects.value(x) for x in outputs))


def probe_unmeasured(state: PlannerState) -> None:
    """With ``eager_cheap_streams``, call once each stream that neither the history nor this
    run has measured, on its first real input: one call decides whether it is cheap enough
    to be eager (:func:`.effort.observed_cheap`) before the first search rather than after a
    search that treated it optimistically (cold kitchen_symbolic: 4 searches -> 1, median
    CPU ~0.19 -> ~0.05 s, as with a warm history). The call's outputs are kept like any
    other's; a stream with no real input yet is probed once it has one."""
    for external in state.externals.values():
        name = external.name
        if state.bindings[name].info.eager or (isinstance(external, Stream) and external.fluents):
            continue
        stats = state.stream_stats.get(name)
        if (stats is not None and stats.calls) or state.history.get(name, {}).get("calls"):
            continue
        inputs = next(iter(state.bindings_of(external, state.facts)), None)
        if inputs is not None:
            state.call(state.instance(name, inputs))


def evaluate_eager(state: PlannerState) -> None:
    """Call every eager stream (``StreamInfo.eager``) once on all real inputs, to a fixpoint.

    Cheap, decisive streams (collision tests, closed-form kinematics) are better evaluated
    for real than assumed optimistically: it keeps optimistic placeholders few. Streams
    observed to be cheap (:func:`.effort.observed_cheap`) count as eager too.
    """
    _eager_fixpoint(state)
    if state.config.eager_cheap_streams:
        # After the fixpoint: the probe call then sees what the eager streams derived (a
        # sampler may use it, e.g. to offer last the places where objects already stand).
        probe_unmeasured(state)
        _eager_fixpoint(state)


def _eager_fixpoint(state: PlannerState) -> None:
    changed = True
    while changed and not state.timed_out():
        changed = False
        for external in state.externals.values():
            if not state.eager(external.name):
                continue
            for inputs in state.new_bindings(external, "eager"):
                instance = state.instance(external.name, inputs)
                if instance.num_calls == 0:
                    state.call(instance)
                    changed = True




def fluent_contexts(state: PlannerState, evaluation: OptimisticEvaluation,
                    discrete: DiscreteResult) -> dict[InstanceKey, tuple[Fact, ...]]:
    """For each optimistic instance of a ``:fluents`` stream the plan relies on, the state
    facts (of its fluent predicates) just before the first action that uses its output."""
    contexts: dict[InstanceKey, tuple[Fact, ...]] = {}
    if discrete.actions is None or discrete.task is None or discrete.outcome is None:
        return contexts
    task = discrete.task
    for step, action in enumerate(discrete.actions):
        for fact in action.static_pre:
            key = evaluation.fact_producer.get(fact)
            if key is None or key in contexts:
                continue
            external = state.externals[key[0]]
            if isinstance(external, Stream) and external.fluents:
                facts = (task.facts[i] for i in discrete.outcome.states[step])
                contexts[key] = state.fluent_context(key[0], facts)
    return contexts


def bind_context(context: tuple[Fact, ...], binding: dict[str, str]) -> tuple[Fact, ...] | None:
    """A fluent context with placeholders replaced by their bound values (None: unbound)."""
    bound = tuple(sorted((f[0], *(binding.get(a, a) for a in f[1:])) for f in context))
    if any(a.startswith("#") for fact in bound for a in fact[1:]):
        return None
    return bound
