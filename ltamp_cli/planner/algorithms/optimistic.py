"""Optimistic evaluation of streams, shared by the focused, binding and adaptive algorithms.

Instances not yet (fully) called certify their facts with placeholder objects ``#name`` up to
a complexity bound (complexity of an instance = summed complexity of its inputs + calls
made; the limit on it is checked by PDDLStream's rule, the highest, see
:func:`instance_level`); a plan over real and optimistic facts is then retraced to the
*stream plan* of instances whose calls would make its optimistic facts real. Below the
limit, two penalties raise a generator instance's complexity: its stream *family* kept
failing (:mod:`.families`), or it is one pending instance over sampled values too many
(:data:`MAX_UNIQUE_OVER_SAMPLES`); neither applies at the limit, where "infeasible" is
decided.

Shared placeholders (PDDLStream's shared optimistic objects, ``StreamInfo(opt_gen_fn=
PartialInputs(...))``, see :func:`_share_group`): with an explicit policy, PDDLStream's
rule (``PartialInputs()``: one placeholder per output shared by all the stream's instances;
``PartialInputs("?o")``: by the instances with the same ``?o``). By default, an instance
with placeholders among its inputs shares its output placeholders with the instances of
its stream that have the same placeholder inputs, whatever their real inputs (PDDLStream's
``PartialInputs`` over the inputs that hold placeholders): the optimistic task then gets one
output per stream and tuple of optimistic inputs, so its objects, and the actions over
them, grow with the placeholders rather than with their products with the real objects
(kitchen_fluent: 64 ``skill-conf`` instances, one per tool, container and placeholder pose,
gave 64 configurations, and the moves between all configurations were most of its ~1,800
actions; now one per placeholder pose). Instances over real values only keep their own (as many as
the real facts give anyway), and so do all instances of a stream whose outputs never reach
a fact that actions change (:func:`stateful_streams`), and of ``:fluents`` streams: what
failed in a context is
recorded per instance and blocks its output facts in that context (``context_blocks``),
which a shared output would wrongly carry to the other instances. An instance becomes
*refined* (its own placeholders) once a plan needed it in a way sharing cannot bind
(:func:`bindable_stream_plan`).

Correctness of binding a plan over shared placeholders. A shared placeholder ``X`` stands
for the output of any of its producing instances; different instances' real outputs differ,
so ``X`` may be bound only if a single instance ``k`` certifies every fact the plan needs
that holds ``X`` as an output of its certifier (a fact over ``X`` as an *input*, e.g. a
motion from ``X``, comes from an instance whose inputs contain ``X`` and is re-instantiated
on the bound value like any placeholder input). Then renaming ``X`` to ``k``'s own
placeholder maps every needed fact to one the unique evaluation has too, so the plan is one
of that task and the stream plan binds ``X`` from ``k``'s call alone. When no single
instance certifies them all (one placeholder serving as two different grasps, poses or
configurations: a plan that exploits the sharing), :func:`bindable_stream_plan` refines a
set of instances that certify them and the plan is discarded: the next search sees those
instances with distinct placeholders. Each such round refines at least one more instance,
so refinement ends (at worst with every instance unique, the behaviour without sharing),
and every plan returned is still validated against the real facts.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Iterator, Mapping
from dataclasses import dataclass, field

from ltamp_cli.planner.algorithms.common import (
    PlannerState,
    external_inputs,
    instantiate_atoms,
)
from ltamp_cli.planner.algorithms.effort import observed_cheap, order_by_effort
from ltamp_cli.planner.algorithms.families import Origin, origin
from ltamp_cli.planner.pddl.check import fluent_predicates
from ltamp_cli.planner.pddl.syntax import (
    OBJECT_TYPE,
    Domain,
    ExternalPredicate,
    Stream,
    StreamFunction,
    effect_atoms,
    formula_atoms,
)
from ltamp_cli.planner.search.clock import check_deadline, sorted_before
from ltamp_cli.planner.search.ground import Context, CostBound, Fact, FactIndex
from ltamp_cli.planner.search.solve import DiscreteResult
from ltamp_cli.planner.streams import External, PartialInputs, StreamInstance

InstanceKey = tuple[str, tuple[str, ...]]


@dataclass
class Placeholders:
    """The placeholder outputs of one solve, kept across its optimistic evaluations (the
    same instance gets the same placeholders each time, so skeletons stay comparable).

    ``unique``: refined instances -> their own placeholders; ``shared``: share-group key
    (see :func:`_share_group`) -> the placeholders its instances share."""

    unique: dict[InstanceKey, tuple[str, ...]] = field(default_factory=dict)
    shared: dict[InstanceKey, tuple[str, ...]] = field(default_factory=dict)
    # Streams whose outputs may be shared (see :func:`stateful_streams`); set on first use.
    stateful: frozenset[str] | None = None
    # Generators whose outputs other streams take as inputs (see feeding_generators).
    feeding: frozenset[str] | None = None

    def new(self, stream: Stream) -> tuple[str, ...]:
        number = len(self.unique) + len(self.shared)
        return tuple(f"#{v[1:]}{number}" for v in stream.outputs)




def stateful_streams(domain: Domain, streams: Iterable[Stream]) -> frozenset[str]:
    """The streams an output of which can become an argument of a fact that actions change
    (directly, or through the inputs of other streams: a configuration feeds the motions
    whose endpoints a move makes the robot's). Only their outputs are shared: an output
    that only certifies (a trajectory in ``(Motion ?q1 ?t ?q2)``) saves no action when
    shared, every instance still certifying its own facts over its inputs, and every plan
    with two of them would need refining (tamp2d_blocked: all its motions, each search).

    Computed on argument positions: ``(P, i)`` is stateful when an action's precondition
    has at position ``i`` of ``P`` a parameter that its effect mentions (or a derived
    predicate's body one of its head's parameters), or, to a fixpoint, when a stream's
    domain has there an input that the stream certifies at a stateful position or in a
    fluent predicate."""
    fluent = fluent_predicates(domain)
    positions: set[tuple[str, int]] = set()
    for action in domain.actions:
        changed = {arg for atom, _ in effect_atoms(action.effect) for arg in atom.args}
        for atom in formula_atoms(action.precondition):
            positions.update((atom.predicate, i) for i, arg in enumerate(atom.args)
                             if arg in changed)
    for axiom in domain.axioms:
        head = {parameter.name for parameter in axiom.head.parameters}
        for atom in formula_atoms(axiom.body):
            positions.update((atom.predicate, i) for i, arg in enumerate(atom.args)
                             if arg in head)
    streams = list(streams)

    def stateful_arguments(stream: Stream) -> set[str]:
        return {arg for atom in stream.certified for i, arg in enumerate(atom.args)
                if atom.predicate in fluent or (atom.predicate, i) in positions}

    while True:
        before = len(positions)
        for stream in streams:
            found = stateful_arguments(stream)
            for atom in (*stream.domain, *stream.fluent_domain):
                positions.update((atom.predicate, i) for i, arg in enumerate(atom.args)
                                 if arg in found)
        if len(positions) == before:
            break
    return frozenset(stream.name for stream in streams
                     if not stateful_arguments(stream).isdisjoint(stream.outputs))


def feeding_generators(externals: Iterable[object]) -> frozenset[str]:
    """The generators an output of which is certified in a predicate that the ``:domain``
    of a stream or function mentions: each of their pending instances multiplies the
    instances of those streams (a configuration, the motions from and to it). Only these
    are limited by :data:`MAX_UNIQUE_OVER_SAMPLES`; the others' instances are as many as
    their inputs (tamp2d_uniform's motions between sampled configurations: limiting them
    made blocked_6's and blocked_8's plans costlier, 117 -> 221 and 147 -> 283 median)."""
    externals = list(externals)
    consumed = {atom.predicate for external in externals
                for atom in getattr(external, "domain", ())}
    return frozenset(
        external.name for external in externals
        if isinstance(external, Stream) and external.outputs and any(
            atom.predicate in consumed and set(atom.args) & set(external.outputs)
            for atom in external.certified))


def _refine(state: PlannerState, placeholders: Placeholders, keys: list[InstanceKey]) -> None:
    """Give instances ``keys``, which one plan needed from one shared placeholder, their
    own placeholders from now on. (Splitting a default-policy group by real input values
    first, so that e.g. the kinematics of one object and grasp at any placeholder pose
    share, took kitchen_fluent adaptive seeds 0-5 from 0.67 to 0.87 s median CPU.)"""
    for key in keys:
        if key not in placeholders.unique:
            placeholders.unique[key] = placeholders.new(_stream(state, key))


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
    # ... by PDDLStream's rule (:func:`instance_level`), and the least of an instance left
    # out by the bound, when measured (at the limit, see :func:`optimistic_evaluation`).
    max_level: dict[str, int] = field(default_factory=dict)
    least_cut: int | None = None
    fact_producer: dict[Fact, InstanceKey] = field(default_factory=dict)
    object_producer: dict[str, InstanceKey] = field(default_factory=dict)
    outputs: dict[InstanceKey, tuple[str, ...]] = field(default_factory=dict)
    cut: bool = False  # an instance was left out by the complexity bound
    # Optimistic facts of :fluents streams -> contexts where the stream already failed.
    context_blocks: dict[Fact, list[Context]] = field(default_factory=dict)
    # Shared placeholder tuple -> the instances that share it (in evaluation order).
    sharing: dict[tuple[str, ...], list[InstanceKey]] = field(default_factory=dict)
    # Stream name -> its instances over sampled real values with their own placeholders in
    # this evaluation (see :data:`MAX_UNIQUE_OVER_SAMPLES`).
    unique_over_samples: dict[str, int] = field(default_factory=dict)


# Instances over real values only keep their own placeholders, but only this many per
# stream among those with a sampled input (a value a stream made, not a problem object);
# the others share theirs with the instances over the same problem objects, as PDDLStream's
# default shared optimistic outputs do (:func:`_overflow_group`). Each sample multiplies
# such instances (every sampled pose x every sampled grasp x every robot gives a
# kinematics instance) and, each with its own configuration, the motions between all pairs
# of them: the hidden suite's handoff_2 reached 198 pending kinematics instances and
# 23,086 motion placeholders, 1-2 s per search. Instances within the limit keep their
# placeholders across evaluations, refined ones too.
MAX_UNIQUE_OVER_SAMPLES = 32

# Candidate instances evaluated between two deadline checks (a check costs ~50 ns).
DEADLINE_STRIDE = 256


def optimistic_evaluation(state: PlannerState, complexity: int,
                          placeholders: Placeholders,
                          held_back: FailedSiblings | None = None
                          ) -> OptimisticEvaluation:
    """The real facts and the optimistic ones of the instances within ``complexity``
    (summed input levels + calls). At or above the algorithms' limit (``max_complexity`` +
    the highest real level), also ``least_cut``: the least complexity by PDDLStream's rule
    (:func:`instance_level`) of an instance left out, so that an "infeasible" answer never
    rests on the sum. ``held_back``: never-called instances with a failed sibling are left
    out too (:func:`failed_siblings`; the evaluation is then ``cut``)."""
    # A hash-independent order, sorted and loaded in bounded steps (10^5 known facts: one
    # ``sorted`` call would hold the GIL past the deadline).
    # Facts of parked samples stay out (see .parking): the task is then cut.
    parked = state.parked
    index = FactIndex.of_sorted(sorted_before(parked.task_facts(state.facts.members),
                                              state.deadline), state.deadline)
    evaluation = OptimisticEvaluation(index, dict(state.function_values),
                                      dict(state.object_types), cut=bool(parked))
    done: set[InstanceKey] = set()
    levels = evaluation.level
    real_levels = state.object_level
    exact = complexity >= state.config.max_complexity + state.max_object_level()
    # Semi-naive fixpoint: the first round takes the inputs over real facts (enumerated
    # incrementally across evaluations), each later round only joins the facts the previous
    # round added. An instance cut by the bound stays cut (its level depends only on its
    # inputs), so it is not retried.
    since: dict[str, int] | None = None
    families = state.families
    problem_objects = state.problem.objects
    if placeholders.feeding is None:
        placeholders.feeding = feeding_generators(state.externals.values())
    inputs_of_streams = placeholders.feeding

    def placeholder_origin(value: str) -> Origin | None:
        producer = evaluation.object_producer.get(value)
        return None if producer is None else origin(*producer, problem_objects)

    while True:
        before = index.sizes()
        for external in state.externals.values():
            check_deadline(state.deadline)
            if since is None:
                candidates = state.open_real_bindings(external)
                if parked:
                    candidates = [x for x in candidates if not parked.holds(x)]
            else:
                # Bindings whose inputs alone exceed the bound are not even enumerated: an
                # instance's level is at least its inputs' summed levels, so they would be
                # cut (the join still tells whether one exists, for ``cut``). At the limit,
                # only those over it by PDDLStream's rule (see ``least_cut``).
                bound = (CostBound(evaluation.max_level, complexity, highest=True) if exact
                         else CostBound(levels, complexity))
                candidates = list(state.bindings_of(external, index, since, bound))
                if bound.exceeded:
                    evaluation.cut = True
            for number, inputs in enumerate(candidates):
                if number % DEADLINE_STRIDE == 0:
                    # 10^5 candidates of one stream (pairwise collision tests) took the
                    # hidden suite's robots2_4 over 0.5 s past its deadline unchecked.
                    check_deadline(state.deadline)
                key = (external.name, inputs)
                if key in done:
                    continue
                done.add(key)
                # Summed input complexity: values built from several placeholders cost more,
                # so low bounds favour plans over real values. Real inputs count with the
                # highest of their levels (PlannerState.object_level, PDDLStream's max).
                level = (sum([levels.get(x, 0) for x in inputs])
                         + max([real_levels.get(x, 0) for x in inputs], default=0))
                highest = instance_level(inputs, evaluation.max_level, real_levels)
                real = state.instances.get(key)
                if held_back and (real is None or not real.num_calls) and held_back.holds(key):
                    evaluation.cut = True
                    continue
                if real is not None:
                    if real.disabled or (real.exhausted and not _pending_test(real)):
                        continue
                    level += real.num_calls
                    highest += real.num_calls
                if not exact and isinstance(external, Stream) and external.outputs:
                    # Below the limit only: "infeasible" is decided without either.
                    if external.name in inputs_of_streams:
                        level += _overflow_penalty(evaluation, external, inputs, problem_objects)
                    if families.has_failing(external.name):
                        level += families.instance_penalty(external.name, inputs,
                                                           problem_objects,
                                                           placeholder_origin)
                if level > complexity:
                    evaluation.cut = True
                    if exact and (evaluation.least_cut is None
                                  or highest < evaluation.least_cut):
                        evaluation.least_cut = highest
                    continue
                _add_optimistic(state, evaluation, key, level, placeholders, highest)
        if index.sizes() == before:
            return evaluation
        since = before


def _share_group(key: InstanceKey, policy: PartialInputs | None,
                 parameters: tuple[str, ...]) -> InstanceKey | None:
    """The key of the shared placeholders of instance ``key`` (``None``: its own).

    With an explicit ``PartialInputs`` policy, PDDLStream's rule: shared by the instances
    that agree on the selected inputs. By default (no policy): instances over real values
    only keep their own (as many as the real facts give anyway); an instance with
    placeholder inputs shares with those that have the same placeholder inputs (its outputs
    are taken to depend on its optimistic inputs only). Measured against the alternatives
    (adaptive, seeds 0-5, median CPU s, interleaved on a loaded machine; tamp2d_4blocks /
    kitchen_fluent): this rule 0.077 / 0.69; the first 16 instances over placeholders
    unique, the rest sharing one (the rule this replaced) 0.081 / 0.56; one shared by all
    instances over placeholders (PDDLStream's ``PartialInputs()`` default) 0.19 / 0.68,
    since nearly every 4blocks plan needs two blocks' kinematics from the one shared
    configuration and is refined, one search per pair; that, with the whole stream made
    unique at its first refinement 0.085 / 1.01, or split by real inputs 0.075 / 1.08; one
    unique instance per real-input tuple, the rest sharing, 0.16 / 0.85; no sharing 0.077
    / 0.93. tamp2d_uniform_tight_8 and kitchen_symbolic: no change (their instances over
    placeholders do not share a placeholder input).
    """
    name, inputs = key
    if policy is not None:
        selected = policy.selected(parameters)
        return None if selected is None else (name, tuple(inputs[i] for i in selected))
    optimistic = tuple(x for x in inputs if x.startswith("#"))
    return (name, optimistic) if optimistic else None


def _overflow_penalty(evaluation: OptimisticEvaluation, external: Stream,
                      inputs: tuple[str, ...], problem_objects: Mapping[str, object]) -> int:
    """Extra levels for a candidate instance of generator ``external`` over real values
    with a sampled input: 0 for the first :data:`MAX_UNIQUE_OVER_SAMPLES` of its stream in
    this evaluation (in the evaluation's deterministic order: older samples first), then
    2, 4, 8, ... for each further block of as many. Instances over problem objects only
    (as many as the problem makes) or over placeholders are not counted."""
    if external.fluents or any(x.startswith("#") for x in inputs) or all(
            x in problem_objects for x in inputs):
        return 0
    rank = evaluation.unique_over_samples.get(external.name, 0)
    evaluation.unique_over_samples[external.name] = rank + 1
    if rank < MAX_UNIQUE_OVER_SAMPLES:
        return 0
    return 2 ** (rank // MAX_UNIQUE_OVER_SAMPLES)


def instance_level(inputs: Iterable[str], levels: dict[str, int],
                   real_levels: dict[str, int]) -> int:
    """Complexity of an instance before its calls by PDDLStream's rule: the highest level
    of its inputs (placeholders: ``levels``; real objects: ``real_levels``; absent: 0).

    PDDLStream combines the complexities of an instance's domain facts with
    ``COMPLEXITY_OP = max`` (``algorithms/common.py``; ``Instantiator.compute_complexity``
    and the skeleton queue's ``compute_index_complexity`` too), then adds the calls made +
    1 for a stream with outputs. The bound here admits instances by the summed levels of
    their placeholder inputs instead, an order that favours plans over real values (with
    the maximum, the adaptive searches of tests/planner/test_cheap_tests_eager.py's tight
    placements went from 204 to 244 over 40 seeds, tamp2d_blocked's median plan cost from
    62 to 96). But the sum counts a shared ancestor once per path to it (a value combining
    two values of level k costs 2k + 1): under ``max_complexity`` (20) a plan six layers
    deep was answered "infeasible" (tests/pddlstream/test_complexity_max.py). So the
    limit is checked by this rule (``OptimisticEvaluation.least_cut``), and the bound
    grows past it while an instance within the limit is still left out."""
    return max([levels[x] if x in levels else real_levels.get(x, 0) for x in inputs],
               default=0)


def within_limit(state: PlannerState, evaluation: OptimisticEvaluation) -> bool:
    """Whether ``evaluation`` left out an instance whose complexity by PDDLStream's rule is
    within the algorithms' limit (``max_complexity`` + the highest real level): then the
    bound must grow on rather than the answer be "infeasible"."""
    limit = state.config.max_complexity + state.max_object_level()
    return evaluation.least_cut is not None and evaluation.least_cut <= limit


def _pending_test(instance: StreamInstance) -> bool:
    return instance.is_test and instance.num_calls == 0


def _add_optimistic(state: PlannerState, evaluation: OptimisticEvaluation, key: InstanceKey,
                    level: int, placeholders: Placeholders, highest: int) -> bool:
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
        outputs = placeholders.unique.get(key, ())
        if placeholders.stateful is None:
            placeholders.stateful = stateful_streams(
                state.problem.domain,
                (x for x in state.externals.values() if isinstance(x, Stream)))
        policy = state.bindings[name].info.opt_gen_fn
        group = None if external.fluents or name not in placeholders.stateful else (
            _share_group(key, policy, external.inputs))
        if outputs or group is None:
            if not outputs:
                outputs = placeholders.unique[key] = placeholders.new(external)
            for placeholder in outputs:
                evaluation.level[placeholder] = level + 1
                evaluation.max_level[placeholder] = highest + 1
                evaluation.object_producer[placeholder] = key
        else:
            outputs = placeholders.shared.get(group, ())
            if not outputs:
                outputs = placeholders.shared[group] = placeholders.new(external)
            sharers = evaluation.sharing.setdefault(outputs, [])
            sharers.append(key)
            for placeholder in outputs:
                # The least level of its producers (the level a unique one would have).
                known = evaluation.level.get(placeholder)
                evaluation.level[placeholder] = level + 1 if known is None else min(
                    known, level + 1)
                evaluation.max_level[placeholder] = min(
                    evaluation.max_level.get(placeholder, highest + 1), highest + 1)
                evaluation.object_producer.setdefault(placeholder, key)
        evaluation.outputs[key] = outputs
        for placeholder in outputs:
            evaluation.object_types[placeholder] = OBJECT_TYPE
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


def bindable_stream_plan(state: PlannerState, evaluation: OptimisticEvaluation,
                         needed: Iterable[Fact], placeholders: Placeholders
                         ) -> list[InstanceKey] | None:
    """The stream plan of an optimistic plan whose preimage is ``needed``, with each shared
    placeholder bound from one instance; ``None`` when sharing made the plan unbindable:
    the instances it needed from one shared placeholder are refined (given their own
    placeholders) and the caller searches again (see the module docstring)."""
    needed = sorted(needed)
    if evaluation.sharing and not _attribute_shared(state, evaluation, needed, placeholders):
        return None
    plan = stream_plan(state, evaluation, needed)
    if evaluation.sharing:
        # Two instances of one shared placeholder can still be in the plan for facts that do
        # not hold it (a certified fact over inputs only): each would bind it.
        users: dict[tuple[str, ...], list[InstanceKey]] = {}
        for key in plan:
            outputs = evaluation.outputs.get(key, ())
            if outputs in evaluation.sharing:
                users.setdefault(outputs, []).append(key)
        clashing = [key for keys in users.values() if len(keys) > 1 for key in keys]
        if clashing:
            _refine(state, placeholders, clashing)
            return None
    return plan


def _stream(state: PlannerState, key: InstanceKey) -> Stream:
    external = state.externals[key[0]]
    assert isinstance(external, Stream)
    return external


def _attribute_shared(state: PlannerState, evaluation: OptimisticEvaluation,
                      needed: list[Fact], placeholders: Placeholders) -> bool:
    """Make one instance the producer of each shared placeholder tuple the plan needs: the
    one that certifies every needed fact holding it as an output. Where no single instance
    does, refine a greedy smallest set of instances that do, and return False."""
    shared_of = {p: outputs for outputs in evaluation.sharing for p in outputs}
    pins: dict[tuple[str, ...], list[Fact]] = {}
    for fact in needed:
        if fact in state.facts.members or fact not in evaluation.fact_producer:
            continue
        for group in dict.fromkeys(shared_of[a] for a in fact[1:] if a in shared_of):
            pins.setdefault(group, []).append(fact)
    certified: dict[InstanceKey, set[Fact]] = {}
    split = False
    for group, facts in pins.items():
        sharers = evaluation.sharing[group]
        for key in sharers:
            if key not in certified:
                stream = _stream(state, key)
                mapping = dict(zip(stream.inputs, key[1], strict=True))
                mapping.update(zip(stream.outputs, group, strict=True))
                certified[key] = set(instantiate_atoms(stream.certified, mapping))
        # Facts holding the placeholder as an input come from other instances.
        remaining = [f for f in facts if any(f in certified[k] for k in sharers)]
        chosen: list[InstanceKey] = []
        while remaining:
            best = max(sharers, key=lambda k: sum(f in certified[k] for f in remaining))
            chosen.append(best)
            remaining = [f for f in remaining if f not in certified[best]]
        if len(chosen) == 1:
            producer = chosen[0]
            # All its facts, also those the plan needs only as the domain of a stream that
            # takes the placeholder as input (a motion's (Conf #q)).
            for fact in certified[producer]:
                if fact in evaluation.fact_producer:
                    evaluation.fact_producer[fact] = producer
            for placeholder in group:
                evaluation.object_producer[placeholder] = producer
        elif chosen:
            split = True
            _refine(state, placeholders, chosen)
    return not split


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


def record_rejection(state: PlannerState, consumed: tuple[str, ...],
                     made_by: dict[str, tuple[StreamInstance, tuple[str, ...]]]) -> None:
    """After a test rejected the values ``consumed``: when one generator of the binding
    sampled them (``made_by``) and the others are the problem's own, its output was rejected
    against the problem, which is evidence against that generator rather than against a
    combination of samples; recorded in ``state.rejected_outputs``."""
    producers = {id(made_by[x][0]): made_by[x] for x in consumed if x in made_by}
    if len(producers) != 1 or not all(x in made_by or x in state.problem.objects
                                      for x in consumed):
        return
    instance, output = next(iter(producers.values()))
    if isinstance(instance.external, Stream) and not instance.is_test:
        state.rejected_outputs.setdefault((instance.name, instance.inputs), set()).add(output)


@dataclass(frozen=True)
class FailedSiblings:
    """Generator instances that *failed*: ran out with every output rejected
    (:func:`record_rejection`). ``signatures``: (stream, position, the other inputs) of
    each failed instance and each position that holds one of the problem's own objects
    (``objects``)."""

    signatures: frozenset[tuple[str, int, tuple[str, ...]]]
    # The streams of the failed instances: other streams' instances are not siblings (the
    # check runs for every candidate instance of a speculative evaluation).
    streams: frozenset[str] = frozenset()
    objects: Collection[str] = frozenset()

    def __bool__(self) -> bool:
        return bool(self.signatures)

    def holds(self, key: InstanceKey) -> bool:
        """Whether instance ``key`` differs from a failed instance of its stream in one
        input, where both hold one of the problem's own objects (the failed instance
        itself is exhausted, so not evaluated)."""
        name, inputs = key
        return name in self.streams and any(
            inputs[i] in self.objects
            and (name, i, inputs[:i] + inputs[i + 1:]) in self.signatures
            for i in range(len(inputs)))


def failed_siblings(state: PlannerState) -> FailedSiblings:
    """The failed generator instances of the solve so far, as :class:`FailedSiblings`.

    Why a speculative search leaves their never-called siblings out: such a search exploits
    what sampling learned, and a sibling of a generator that failed (same stream, inputs
    that differ in one of the problem's objects: the same region for another object) is the
    opposite, an untried copy whose level is lowest because it was never called.
    kitchen_fluent: the coaster's one slot holds the saucer; once
    ``sample-pose(mug, coaster)`` failed there, every speculative search on 7 of 10 seeds
    parked the pitcher on a fresh ``sample-pose(pitcher, coaster)`` pose (the table sampler
    it had used had calls, so a higher level), whose stream plan died at once on the same
    slot. Only where the differing value is the problem's own on both sides: instances
    over sampled values are as many as the samples, and one sample's failure says little
    about another's (PDDLStream's continuous_tamp/rmmp, whose ``s-intersection`` over
    sampled modes failed often: held back, its solves took about twice the CPU). Full
    searches see every instance, so completeness is unchanged."""
    objects = state.problem.objects
    signatures: set[tuple[str, int, tuple[str, ...]]] = set()
    for key, outputs in state.rejected_outputs.items():
        instance = state.instances.get(key)
        if instance is None or not instance.exhausted or not set(instance.results) <= outputs:
            continue
        name, inputs = key
        for i in range(len(inputs)):
            if inputs[i] in objects:
                signatures.add((name, i, inputs[:i] + inputs[i + 1:]))
    return FailedSiblings(frozenset(signatures),
                          frozenset(name for name, _, _ in signatures), objects)


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


def evaluate_eager(state: PlannerState, complexity: int | None = None) -> None:
    """Call every eager stream (``StreamInfo.eager``) once on all real inputs, to a fixpoint.

    Cheap, decisive streams (collision tests, closed-form kinematics) are better evaluated
    for real than assumed optimistically: it keeps optimistic placeholders few. Streams
    observed to be cheap (:func:`.effort.observed_cheap`) count as eager too. With
    ``complexity`` (the skeleton algorithms' bound), so do cheap functions on or feeding a
    cycle of the stream graph, on inputs below that level (see
    :meth:`PlannerState.eager_within_level`).
    """
    for _ in evaluate_eager_steps(state, complexity):
        pass


def evaluate_eager_steps(state: PlannerState, complexity: int | None = None
                         ) -> Iterator[None]:
    """:func:`evaluate_eager`, yielding after each stream call of its fixpoints (an
    interleaved incremental member is cut there, see :mod:`.interleave`)."""
    yield from _eager_fixpoint(state, complexity)
    if state.config.eager_cheap_streams:
        # After the fixpoint: the probe call then sees what the eager streams derived (a
        # sampler may use it, e.g. to offer last the places where objects already stand).
        probe_unmeasured(state)
        yield from _eager_fixpoint(state, complexity)


def _eager_fixpoint(state: PlannerState, complexity: int | None) -> Iterator[None]:
    changed = True
    while changed and not state.timed_out():
        changed = False
        for external in state.externals.values():
            name = external.name
            if state.eager(name):
                candidates = state.deferred_eager.pop(name, [])
                candidates.extend(state.new_bindings(external, "eager"))
            elif complexity is not None and state.eager_within_level(name):
                candidates = _below_level(state, external, complexity)
            else:
                continue
            # Tuples over parked samples wait for their release (see .parking).
            candidates = state.parked.hold_back(name, candidates)
            for inputs in candidates:
                instance = state.instance(name, inputs)
                if instance.num_calls == 0:
                    state.call(instance)
                    changed = True
                    yield


def _below_level(state: PlannerState, external: External, complexity: int
                 ) -> list[tuple[str, ...]]:
    """The real input tuples of ``external`` whose inputs are all below level
    ``complexity`` (so that its output is at most at it); the others wait for a higher
    bound."""
    waiting = state.deferred_eager.setdefault(external.name, [])
    waiting.extend(state.new_bindings(external, "eager"))
    level = state.object_level
    ready = [inputs for inputs in waiting
             if max([level.get(x, 0) for x in inputs], default=0) < complexity]
    if ready:
        state.deferred_eager[external.name] = [x for x in waiting if x not in set(ready)]
    return ready




@dataclass(frozen=True)
class ContextualStreamPlan:
    """A stream plan with one entry per (instance, state context) it is called in.

    ``entries[i]``: the instance (stream name, inputs) called at position ``i``;
    ``outputs[i]``: the placeholders its output binds (empty for tests); ``contexts[i]``:
    the state facts (of its stream's ``:fluents`` predicates; may hold placeholders) it is
    called under (empty without ``:fluents``); ``steps``: the optimistic plan (action name,
    arguments), each step over the outputs of the entries called in its own state.

    A ``:fluents`` instance that the plan uses at steps in different states gets one entry
    per state (after the first, a copy with placeholders ``#x~n``, and copies of the
    instances that consume its outputs), and the steps in that state take the copy's
    outputs: one call per (instance, context), so each step's output is valid in its own
    state. (With one call in the first state's context, a motion driven twice between the
    same configurations, the world changed in between, made the bound plan fail and a
    search over real facts run in vain.)"""

    entries: tuple[InstanceKey, ...]
    outputs: tuple[tuple[str, ...], ...]
    contexts: tuple[tuple[Fact, ...], ...]
    steps: tuple[tuple[str, tuple[str, ...]], ...]


def fluent_uses(state: PlannerState, evaluation: OptimisticEvaluation,
                discrete: DiscreteResult, plan: Iterable[InstanceKey]
                ) -> dict[InstanceKey, dict[tuple[Fact, ...], list[int]]]:
    """For each optimistic instance of a ``:fluents`` stream in ``plan`` that a step of the
    optimistic plan relies on: each state context it is used in (the facts of its fluent
    predicates just before the step, in order of first use) -> the steps (plan positions)."""
    uses: dict[InstanceKey, dict[tuple[Fact, ...], list[int]]] = {}
    if discrete.actions is None or discrete.task is None or discrete.outcome is None:
        return uses
    keys = set(plan)
    task = discrete.task
    for step, action in enumerate(discrete.actions):
        for fact in action.static_pre:
            key = evaluation.fact_producer.get(fact)
            if key is None or key not in keys:
                continue
            external = state.externals[key[0]]
            if isinstance(external, Stream) and external.fluents:
                facts = (task.facts[i] for i in discrete.outcome.states[step])
                steps = uses.setdefault(key, {}).setdefault(
                    state.fluent_context(key[0], facts), [])
                if not steps or steps[-1] != step:
                    steps.append(step)
    return uses


def contextual_stream_plan(state: PlannerState, evaluation: OptimisticEvaluation,
                           plan: Iterable[InstanceKey], discrete: DiscreteResult
                           ) -> ContextualStreamPlan:
    """``plan`` (from :func:`bindable_stream_plan`) with an entry per (instance, context)
    (see :class:`ContextualStreamPlan`). A copy is placed after its original and after the
    entries that produce its inputs and the placeholders of its context; a copy of an
    instance that consumes a copied output gets fresh outputs too (e.g. a test of the
    second trajectory)."""
    plan = list(plan)
    steps = [(a.name, tuple(a.args)) for a in discrete.actions or []]
    uses = fluent_uses(state, evaluation, discrete, plan)
    # Entries as [key, outputs, context]; the originals keep their identity for positions.
    entries: list[list] = [[key, evaluation.outputs.get(key, ()),
                            next(iter(uses[key]), ()) if key in uses else ()]
                           for key in plan]
    originals = list(entries)
    copies = 0
    for position, key in enumerate(plan):
        for context, used_at in list(uses.get(key, {}).items())[1:]:
            copies += 1
            rename: dict[str, str] = {}
            for later in originals[position:]:
                later_key, later_outputs, later_context = later
                if later is not originals[position] and not any(
                        x in rename for x in later_key[1]):
                    continue
                new_outputs = tuple(f"{x}~{copies}" for x in later_outputs)
                rename.update(zip(later_outputs, new_outputs, strict=True))
                copy = [(later_key[0], tuple(rename.get(x, x) for x in later_key[1])),
                        new_outputs,
                        context if later is originals[position] else tuple(
                            (f[0], *(rename.get(a, a) for a in f[1:]))
                            for f in later_context)]
                needs = set(copy[0][1]) | {a for f in copy[2] for a in f[1:]}
                after = max([i for i, entry in enumerate(entries)
                             if entry is later or not needs.isdisjoint(entry[1])])
                entries.insert(after + 1, copy)
            for step in used_at:
                name, args = steps[step]
                steps[step] = (name, tuple(rename.get(x, x) for x in args))
    entries = _after_their_contexts(entries)
    return ContextualStreamPlan(tuple(e[0] for e in entries), tuple(e[1] for e in entries),
                                tuple(e[2] for e in entries), tuple(steps))


def _after_their_contexts(entries: list[list]) -> list[list]:
    """``entries`` ([instance key, outputs, context]) reordered, stably, so that each one
    comes after the entries whose outputs its inputs or its context's facts hold: the
    earliest entry (in the given order) whose placeholders are all bound goes next.

    The effort order (:func:`stream_plan`) knows an instance's inputs and domain, not the
    placeholders of the state it is used in, so a cheap-to-fail ``:fluents`` instance over
    real configurations could come before the samplers of the poses standing in its state;
    binding then stops at it with the context unbound (``bind_context`` is ``None``), the
    skeleton dies without a call and the next search finds the same plan again
    (kitchen_fluent adaptive: 3 of 116 skeletons in seeds 0-29, each costing searches up to
    the next complexity bound). Given a valid order this returns it unchanged."""
    made: set[str] = {x for entry in entries for x in entry[1]}
    bound: set[str] = set()
    remaining = list(entries)
    ordered: list[list] = []
    while remaining:
        index = next((i for i, entry in enumerate(remaining)
                      if all(x in bound or x not in made
                             for x in (*entry[0][1], *(a for f in entry[2] for a in f[1:])))),
                     0)  # a cycle cannot come from a plan: keep the given order
        ready = remaining.pop(index)
        ordered.append(ready)
        bound.update(ready[1])
    return ordered


def bind_context(context: tuple[Fact, ...], binding: dict[str, str]) -> tuple[Fact, ...] | None:
    """A fluent context with placeholders replaced by their bound values (None: unbound)."""
    bound = tuple(sorted((f[0], *(binding.get(a, a) for a in f[1:])) for f in context))
    if any(a.startswith("#") for fact in bound for a in fact[1:]):
        return None
    return bound
