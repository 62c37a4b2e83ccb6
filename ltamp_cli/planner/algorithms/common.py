"""State shared by the PDDLStream algorithms: known facts, objects, stream instances."""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence, Sized
from dataclasses import asdict, dataclass, field

import numpy as np

from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.effort import Effort, estimate_effort, observed_cheap
from ltamp_cli.planner.algorithms.families import StreamFamilies
from ltamp_cli.planner.algorithms.parking import ParkedSamples
from ltamp_cli.planner.objects import ObjectTable
from ltamp_cli.planner.pddl.syntax import (
    OBJECT_TYPE,
    And,
    Atom,
    ExternalPredicate,
    Stream,
    StreamFunction,
)
from ltamp_cli.planner.problem import PlanningProblem
from ltamp_cli.planner.result import (
    INFEASIBLE,
    SOLVED,
    TIMEOUT,
    Certificate,
    PlanResult,
    PlanStep,
    StreamResult,
)
from ltamp_cli.planner.search.engine import SearchTimeout
from ltamp_cli.planner.search.ground import (
    Context,
    CostBound,
    Fact,
    FactIndex,
    join_tuples,
)
from ltamp_cli.planner.search.incremental import GroundingCache
from ltamp_cli.planner.search.normalize import LiftedLiteral
from ltamp_cli.planner.search.skeleton import PlanConstraints
from ltamp_cli.planner.search.solve import DiscreteResult, plan_discrete
from ltamp_cli.planner.streams import (
    Binding,
    External,
    StreamInstance,
    StreamStats,
    resolve_bindings,
)
from ltamp_cli.planner.watchdog import CallTracker, RunningCall

ALGORITHMS = ("adaptive", "binding", "focused", "incremental")
MAX_REMEMBERED_SKELETONS = 3
# First expansion budget of searches that may fail (doubles each time one runs out): the
# example problems' successful searches expand tens to a few hundred states, while a failing
# search explores the whole reachable space (thousands of states). As with PDDLStream's
# per-search time limit, running out counts as a failed search. 250 cut a solvable
# kitchen_symbolic search (about 450 expansions) and sent focused into 15-26 searches.
INITIAL_SEARCH_EXPANSIONS = 600
# Incremental samples every stream again after each failed search (that, not a longer
# search, is what usually makes its next search solvable), so it starts lower: 100 took
# tamp2d_4blocks median heuristic evaluations from 3,340 to 978. Since its placements keep
# clear of known poses, its real tasks need 150-400 expansions more often than new samples:
# 300 rather than 100 over 30 seeds, tamp2d_4blocks mean CPU 0.060 -> 0.041 s (max 0.52 ->
# 0.17), kitchen_symbolic 0.100 -> 0.069 s, medians unchanged within noise.
INITIAL_INCREMENTAL_EXPANSIONS = 300


@dataclass(frozen=True)
class PlannerConfig:
    """Options of one planner run (all passed explicitly, nothing global).

    ``max_time`` in seconds; ``seed`` seeds the stream bindings' RNG; ``search`` is the
    discrete search (``ff``, ``lazy-greedy``, ``wastar``, ``fd``); ``unit_costs`` ignores
    action costs. ``success_cost``: keep improving the plan (anytime) until its cost is at
    most this or time runs out (``inf``: return the first plan). ``skeleton``: action
    patterns the plan must follow (see :mod:`ltamp_cli.planner.search.skeleton`);
    ``skeletons``: several such lists, the plan follows one of them; ``constraints``: the
    same as :class:`~ltamp_cli.planner.search.skeleton.PlanConstraints` (partial orders,
    sets of objects; at most one of the three is given, :func:`.api.solve` turns the
    strings into ``constraints``). ``max_cost``: only plans cheaper than this (PDDLStream's
    ``PlanConstraints(max_cost=...)``).
    ``statistics_dir``: where per-domain stream statistics persist across runs (``None``:
    nowhere). Test streams that earlier calls (persisted or in this run) showed to be cheap
    (:func:`.effort.observed_cheap`) are always evaluated eagerly; ``eager_cheap_streams``:
    so is every other stream observed to be cheap; worth it
    for cheap finite samplers (discrete slots), not for continuous samplers that feed
    quadratic eager streams such as motions between all configurations.
    ``stream_cpu_clock``: the clock (CPU seconds) that times stream calls for the decision
    whether a stream is cheap enough to be eager (``None``: the solving thread's CPU clock).
    A call's measured CPU time varies with the machine (a garbage collection or cache
    misses under load can push a 20 us call past the threshold and change the searches), so
    tests that depend on the decision inject a deterministic clock.
    ``incremental_grounding``: ground the solve's successive search tasks with one
    :class:`.GroundingCache` (same tasks, plans and searches; the joins are not redone).
    It pays when the searches reuse most of what they ground: kitchen_fluent's 8-15
    searches, -6 % (adaptive) and -14 % (binding) median CPU; it costs when each search
    brings mostly new instances (tamp2d problems with uniform placements: +10-25 %), so it
    is off by default (docs/results/planner/issue19.md).
    ``interleave``: the optimistic algorithms (adaptive, binding, focused) run an
    incremental member beside them (a two-member portfolio, see :mod:`.interleave`): alone
    for their first ``interleave.GRACE_UNITS`` (270,000, about 0.28 s of CPU) of work, then
    giving the member ``interleave.SHARE`` (0.4) work units per unit of theirs past that
    grace, so about 0.4 of the optimistic member's CPU, 0.29 of the solve's; work is
    counted in load-independent units, not seconds. One member per solve: anytime rounds
    go on with it. Not for ``:fluents`` streams.
    """

    algorithm: str = "adaptive"
    max_time: float = 60.0
    seed: int = 0
    search: str = "ff"
    unit_costs: bool = False
    initial_complexity: int = 0
    max_complexity: int = 20
    success_cost: float = float("inf")
    skeleton: tuple[str, ...] = ()
    skeletons: tuple[tuple[str, ...], ...] = ()
    constraints: PlanConstraints | None = None
    max_cost: float = float("inf")
    statistics_dir: str | None = None
    eager_cheap_streams: bool = False
    threads: int | None = 1  # thread-pool limit while solving (ltamp_cli.threads)
    incremental_grounding: bool = False
    interleave: bool = True
    stream_cpu_clock: Callable[[], float] | None = None


def external_domain(external: External) -> tuple[Atom, ...]:
    return external.domain


def external_inputs(external: External) -> tuple[str, ...]:
    if isinstance(external, Stream):
        return external.inputs
    if isinstance(external, StreamFunction):
        return external.head.args
    return external.head.args


def instantiate_atoms(atoms: Iterable[Atom], mapping: Mapping[str, str]) -> list[Fact]:
    get = mapping.get  # map(get, args, args): get(a, a) per argument, without a generator
    return [(atom.predicate, *map(get, atom.args, atom.args)) for atom in atoms]


def certified_facts(instance: StreamInstance, outputs: tuple[str, ...]) -> list[Fact]:
    """Facts an instance certifies for one output tuple (tests: for no outputs)."""
    external = instance.external
    mapping = dict(zip(external_inputs(external), instance.inputs, strict=True))
    if isinstance(external, Stream):
        mapping.update(zip(external.outputs, outputs, strict=True))
        return instantiate_atoms(external.certified, mapping)
    if isinstance(external, ExternalPredicate):
        return instantiate_atoms((external.head,), mapping)
    return []


def recursive_streams(externals: Iterable[External]) -> frozenset[str]:
    """Names of the generators that lie on a cycle of the stream graph: an edge goes from
    an external to every external whose ``:domain`` mentions a predicate it certifies (for
    a generator, about one of its outputs), so a cycle is a way for a stream's outputs to
    reach its own inputs, through other streams or not (successor-state samplers: a mode,
    a lock state, a configuration sampled near another). Such a stream can make
    arbitrarily long chains of new objects."""
    return _stream_cycles(list(externals))[0]


def feeding_streams(externals: Iterable[External]) -> frozenset[str]:
    """Names of the generators not on a cycle of the stream graph (see
    :func:`recursive_streams`) whose outputs reach the inputs of one that is: the poses,
    kinematics and motions that PDDLStream's unfactored example feeds to its
    state-successor functions."""
    return _stream_cycles(list(externals))[1]


def _stream_cycles(externals: list[External]) -> tuple[frozenset[str], frozenset[str]]:
    """(generators on a cycle of the stream graph, other generators reaching one)."""
    produces: dict[str, set[str]] = {}
    consumes: dict[str, set[str]] = {}
    for external in externals:
        if isinstance(external, Stream):
            made = set(external.outputs)
            produces[external.name] = {atom.predicate for atom in external.certified
                                       if not made or made & set(atom.args)}
        elif isinstance(external, ExternalPredicate):
            produces[external.name] = {external.head.predicate}
        else:
            produces[external.name] = set()
        consumes[external.name] = {atom.predicate for atom in external_domain(external)}
    successors = {name: [other for other in consumes if produced & consumes[other]]
                  for name, produced in produces.items()}
    found: set[str] = set()
    reaches: dict[str, set[str]] = {}
    for external in externals:
        if not isinstance(external, Stream) or external.is_test:
            continue
        stack = list(successors[external.name])
        seen: set[str] = set()
        while stack:
            name = stack.pop()
            if name not in seen:
                seen.add(name)
                stack.extend(successors[name])
        reaches[external.name] = seen
        if external.name in seen:
            found.add(external.name)
    feeding = {name for name, seen in reaches.items()
               if name not in found and not seen.isdisjoint(found)}
    return frozenset(found), frozenset(feeding)


#: CPU (microseconds) of a stream call that its count alone stands for in
#: :class:`WorkCount`; only the excess of a slower call is charged as measured (10 ms: far
#: above the calls of symbolic and 2D domains, so their counts stay load-proof; far below a
#: motion plan's or a physics pre-check's 0.1-3 s).
SLOW_CALL_US = 10_000.0


@dataclass
class WorkCount:
    """What a solve did, counted the same way whatever the machine's load (the interleaved
    incremental member's grace and share are measured in it, see :mod:`.interleave`):
    ``calls``: stream calls; ``facts``: facts in the initial states of the searched tasks;
    ``grounded``: their ground actions and axioms; ``evaluated``: states the searches
    evaluated (a followed guess evaluates none); ``heuristic``: the sum over searches of
    evaluated states times ground actions and axioms (a state's heuristic costs about the
    task's size); ``slow_call_us``: the CPU microseconds by which stream calls exceeded
    :data:`SLOW_CALL_US` each (measured, so not load-proof, but zero wherever calls are
    cheap: a count of calls says nothing about a domain whose calls plan motions or run
    physics, where one call costs as much as thousands of searched states)."""

    calls: int = 0
    facts: int = 0
    grounded: int = 0
    evaluated: int = 0
    heuristic: int = 0
    slow_call_us: float = 0.0

    def add_call(self, cpu_s: float) -> None:
        """Count one stream call that took ``cpu_s`` seconds of CPU."""
        self.calls += 1
        self.slow_call_us += max(0.0, cpu_s * 1e6 - SLOW_CALL_US)

    def add_search(self, init_facts: int, result: DiscreteResult) -> None:
        """Count one search: ``init_facts`` facts grounded into ``result``'s task."""
        size = len(result.grounding.actions) + len(result.grounding.axioms)
        evaluated = 0 if result.outcome is None or result.outcome.guessed else (
            result.outcome.evaluated)
        self.facts += init_facts
        self.grounded += size
        self.evaluated += evaluated
        self.heuristic += evaluated * size


@dataclass
class PlannerState:
    """Facts known to be true (from the problem or certified by streams) and objects."""

    problem: PlanningProblem
    config: PlannerConfig
    objects: ObjectTable
    object_types: dict[str, str]
    externals: dict[str, External]
    bindings: dict[str, Binding]
    facts: FactIndex = field(default_factory=FactIndex)
    function_values: dict[Fact, float] = field(default_factory=dict)
    instances: dict[tuple[str, tuple[str, ...]], StreamInstance] = field(default_factory=dict)
    producers: dict[Fact, StreamResult] = field(default_factory=dict)
    stream_stats: dict[str, StreamStats] = field(default_factory=dict)
    start_time: float = field(default_factory=time.perf_counter)
    search_time: float = 0.0
    search_cpu: float = 0.0  # CPU seconds of this thread in searches
    grounding_time: float = 0.0  # of the searches' tasks (part of search_time)
    sampling_time: float = 0.0
    # The stream call in progress and whether the caller abandoned this solve (see
    # :mod:`ltamp_cli.planner.watchdog`).
    tracker: CallTracker = field(default_factory=CallTracker)
    iterations: int = 0
    searches: int = 0
    work: WorkCount = field(default_factory=WorkCount)
    # Grounds this solve's successive search tasks without redoing the joins.
    grounding_cache: GroundingCache = field(default_factory=GroundingCache)
    last_skeletons: list[list[str]] = field(default_factory=list)
    cost_bound: float | None = None  # anytime mode: only plans cheaper than this
    # Facts certified by :fluents streams -> the state facts they were computed under.
    # A context is (fluent predicates, the facts of them that held): it holds in a state
    # whose facts of those predicates are exactly these.
    fluent_requirements: dict[Fact, list[Context]] = field(default_factory=dict)
    # Complexity level of objects made by stream calls (absent: 0), as PDDLStream's result
    # complexity, but only where outputs can feed their own stream again, or feed such a
    # stream (:attr:`leveled`): an output of a call of such a stream is at the highest level
    # of the call's inputs plus the number of calls its instance made, this one included;
    # other streams' outputs are at their inputs' highest level. (Feeding streams too: in
    # PDDLStream's unfactored example every new pose sample at level 0 opened one more
    # one-step plan from the initial state, so the bound hardly grew.) Optimistic instances over
    # an object start at its level (:func:`.optimistic.optimistic_evaluation`), so that
    # each complexity bound admits finitely many optimistic plans: with every sampled state
    # at level 0, each new sample of a successor-state stream opened one more short
    # optimistic plan ending in it (found at the same bound, so the bound never grew and
    # the longer plans the problem needs stayed out of reach: PDDLStream's rmmp, where every
    # sampled placement mode gave a two-switch plan whose goal test fails).
    object_level: dict[str, int] = field(default_factory=dict)
    # (:fluents stream, inputs) -> the contexts in which a call of it failed.
    failed_contexts: dict[tuple[str, tuple[str, ...]], list[Context]] = field(
        default_factory=dict)
    # Generator instance -> its outputs that a test rejected against values that no stream
    # sampled in that binding (see optimistic.record_rejection, failed_siblings).
    rejected_outputs: dict[tuple[str, tuple[str, ...]], set[tuple[str, ...]]] = field(
        default_factory=dict)
    # Per-stream totals persisted by earlier runs of this domain (calls, successes, time_s).
    history: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    # (purpose, stream name) -> ``facts.sizes()`` when the stream's inputs were last
    # enumerated for that purpose (eager evaluation, incremental sampling): later rounds only
    # join what was added since (facts only grow).
    enumerated: dict[tuple[str, str], dict[str, int]] = field(default_factory=dict)
    # Stream name -> the input tuples over real facts found so far (in discovery order)
    # whose instance is not exhausted, so that optimistic evaluations do not join the real
    # facts again each time.
    real_inputs: dict[str, list[tuple[str, ...]]] = field(default_factory=dict)
    # Expansions allowed to a budgeted search (see :meth:`search`).
    search_budget: int = INITIAL_SEARCH_EXPANSIONS
    # Whether a stream certified facts it does not declare (wild outputs): optimistic
    # plans cannot anticipate those, so their failure proves nothing.
    saw_wild_facts: bool = False
    # Generators an instance of which was not exhausted by its first call (not functions).
    multi_output: set[str] = field(default_factory=set)
    # Stream name -> real input tuples enumerated for eager evaluation but not called yet
    # (above the level bound, see :meth:`eager_within_level`).
    deferred_eager: dict[str, list[tuple[str, ...]]] = field(default_factory=dict)
    # Calls and successes per stream family (where the inputs come from, see
    # :mod:`.families`): a family that keeps failing gets its optimistic instances' level
    # raised.
    families: StreamFamilies = field(default_factory=StreamFamilies)
    # The first stream output seen to equal an object the problem gives (one line):
    # evidence against the relaxation's "future outputs are new objects" (see
    # api._infeasibility_unproven).
    coinciding_output: str | None = None
    # Other states of this solve that call the same bindings (the interleaved member, see
    # :mod:`.companions`): an "infeasible" is checked against what their instances made.
    companions: list[PlannerState] = field(default_factory=list)
    # Sampled values a binding's test rejected, kept out of optimistic tasks and eager
    # calls until a full search fails (:mod:`.parking`; only the skeleton algorithms park).
    parked: ParkedSamples = field(default_factory=ParkedSamples)

    @functools.cached_property
    def recursive(self) -> frozenset[str]:
        """The generators whose outputs can feed their own inputs again (see
        :func:`recursive_streams`)."""
        return recursive_streams(self.externals.values())

    @functools.cached_property
    def leveled(self) -> frozenset[str]:
        """The generators whose calls raise their outputs' level (:attr:`object_level`):
        those on a cycle, and those feeding one (:func:`feeding_streams`)."""
        return self.recursive | feeding_streams(self.externals.values())

    def max_object_level(self) -> int:
        """The highest complexity level of a real object (:attr:`object_level`)."""
        return max(self.object_level.values(), default=0)

    def open_real_bindings(self, external: External) -> list[tuple[str, ...]]:
        """The input tuples of ``external`` whose domain facts are real (kept up to date
        semi-naively as facts grow), in discovery order, without those whose instance is
        exhausted: it can certify nothing more, and instances are never un-exhausted, so
        they are dropped for good."""
        known = self.real_inputs.get(external.name, [])
        known.extend(self.new_bindings(external, "real"))
        instances = self.instances
        name = external.name
        known = [inputs for inputs in known
                 if (found := instances.get((name, inputs))) is None or not found.exhausted]
        self.real_inputs[name] = known
        return known

    def new_bindings(self, external: External, purpose: str) -> list[tuple[str, ...]]:
        """Input tuples of ``external`` over the real facts that an earlier call with the
        same ``purpose`` did not return (deduplicated, in a deterministic order)."""
        key = (purpose, external.name)
        since = self.enumerated.get(key)
        self.enumerated[key] = self.facts.sizes()
        return list(dict.fromkeys(self.bindings_of(external, self.facts, since)))

    def effort(self, name: str) -> Effort:
        """Expected success probability and overhead of a call of stream ``name``."""
        return estimate_effort(self.bindings[name].info, self.history.get(name),
                               self.stream_stats.get(name))

    def eager(self, name: str) -> bool:
        """Declared eager, or observed cheap (not for :fluents streams, whose calls need a
        state): with ``config.eager_cheap_streams`` any stream, else test streams only.

        A cheap test left optimistic over real values costs a search per value it rejects:
        on PDDLStream's continuous_tamp (tight), every search planned with one untested pair
        of sampled poses, whose collision test then failed (one search, 0.1-0.4 s, per
        rejected pair, until the time ran out); testing every pair costs microseconds."""
        if self.bindings[name].info.eager:
            return True
        external = self.externals[name]
        if isinstance(external, Stream) and external.fluents:
            return False
        if not self.config.eager_cheap_streams and not (
                isinstance(external, Stream) and not external.outputs):
            return False
        return observed_cheap(self.history.get(name), self.stream_stats.get(name))

    def eager_within_level(self, name: str) -> bool:
        """Whether the skeleton algorithms call ``name`` eagerly on real inputs below their
        complexity bound: a function (every instance called so far was exhausted by its
        first call: ``from_fn``, ``from_list_fn``) observed to be cheap, on or feeding a
        cycle of the stream graph (:attr:`leveled`), without ``:fluents``.

        In a domain that plans over whole states (PDDLStream's unfactored example: a state
        and a motion or a grasp to the successor state), an optimistic plan knows nothing
        of a state's contents, so every transition from a real state looks applicable; left
        optimistic, each one that the function then rejects (the robot is elsewhere, the
        hand is empty) costs a search, and the real states grow by about one per search.
        Called eagerly, the successors of the real states up to the bound are all known
        after microseconds per call, as PDDLStream's incremental algorithm finds them level
        by level; generators (samplers) stay optimistic."""
        external = self.externals[name]
        if (not isinstance(external, Stream) or external.is_test or external.fluents
                or name not in self.leveled or name in self.multi_output):
            return False
        return observed_cheap(self.history.get(name), self.stream_stats.get(name))

    def record_failure(self, instance: StreamInstance) -> None:
        external = instance.external
        if isinstance(external, Stream) and external.fluents:
            key = (instance.name, instance.inputs)
            self.failed_contexts.setdefault(key, []).append(
                (external.fluents, instance.fluent_facts))
    unreachable_goal: list[str] = field(default_factory=list)

    @property
    def deadline(self) -> float:
        return self.start_time + self.config.max_time

    def timed_out(self) -> bool:
        return time.perf_counter() > self.deadline or self.tracker.cancelled

    def add_fact(self, fact: Fact, producer: StreamResult | None = None) -> bool:
        added = self.facts.add(fact)
        if added and producer is not None:
            self.producers[fact] = producer
        return added

    def instance(self, name: str, inputs: tuple[str, ...],
                 fluent_facts: tuple[Fact, ...] = ()) -> StreamInstance:
        key = (name, inputs) if not fluent_facts else (name, inputs, fluent_facts)
        found = self.instances.get(key)  # type: ignore[call-overload]
        if found is None:
            found = StreamInstance(self.externals[name], self.bindings[name], inputs,
                                   fluent_facts)
            self.instances[key] = found  # type: ignore[index]
        return found

    def fluent_context(self, name: str, state_facts: Iterable[Fact]) -> tuple[Fact, ...]:
        """The facts of a state that a stream with ``:fluents`` is called under."""
        external = self.externals[name]
        if not isinstance(external, Stream) or not external.fluents:
            return ()
        return tuple(sorted(f for f in state_facts if f[0] in external.fluents))

    def call(self, instance: StreamInstance) -> list[tuple[str, ...]]:
        """Call an instance once and record what it certified. Returns new output tuples."""
        if self.timed_out():
            raise SearchTimeout  # an abandoned solve calls nothing more
        start = time.perf_counter()
        stats = self.stream_stats.setdefault(instance.name, StreamStats())
        self.tracker.running = RunningCall(instance.name, instance.inputs, start)
        cpu_before = stats.cpu_s
        try:
            outputs = instance.call(self.objects, stats, self.config.stream_cpu_clock)
        except (InputError, KeyboardInterrupt):
            raise
        except BaseException as error:  # user code, even SystemExit: reported on one line
            raise StreamError(instance, error) from error
        finally:
            self.tracker.running = None
            self.sampling_time += time.perf_counter() - start
            self.work.add_call(stats.cpu_s - cpu_before)
        self.add_wild_facts(instance)
        external = instance.external
        if (isinstance(external, Stream) and external.outputs and not external.fluents
                and self.config.algorithm != "incremental"):
            # Only generators are penalised (see .optimistic), and incremental never is; a
            # :fluents stream's failure belongs to the state it was called in.
            self.families.record(instance.name, instance.inputs, bool(outputs), outputs,
                                 self.problem.objects)
        if not instance.exhausted and isinstance(external, Stream) and not external.is_test:
            self.multi_output.add(instance.name)
        if isinstance(external, StreamFunction):
            mapping = dict(zip(external.head.args, instance.inputs, strict=True))
            key = (external.name, *(mapping[a] for a in external.head.args))
            self.function_values[key] = float(instance.value)
            return outputs
        if instance.is_test:
            if instance.value:
                facts = certified_facts(instance, ())
                result = StreamResult(instance.name, instance.inputs, (), tuple(facts))
                for fact in facts:
                    self.add_fact(fact, result)
            return outputs
        exogenous = self.exogenous_context(instance)
        level = max([self.object_level.get(x, 0) for x in instance.inputs], default=0)
        if instance.name in self.leveled:
            level += instance.num_calls  # this call's index + 1
        for output in outputs:
            for name in output:
                self.object_types.setdefault(name, OBJECT_TYPE)
                if self.coinciding_output is None and name in self.problem.objects:
                    self.coinciding_output = (f"stream {instance.name!r} output the "
                                              f"problem's object {name!r}")
                if name not in self.problem.objects and level < self.object_level.get(
                        name, level + 1):
                    self.object_level[name] = level
            facts = certified_facts(instance, output)
            result = StreamResult(instance.name, instance.inputs, output, tuple(facts))
            for fact in facts:
                added = self.add_fact(fact, result)
                if isinstance(instance.external, Stream) and instance.external.fluents:
                    # Holds only in states with the facts the stream was called under.
                    self.fluent_requirements.setdefault(fact, []).append(
                        (instance.external.fluents, instance.fluent_facts))
                elif exogenous is not None and (added or fact in self.fluent_requirements):
                    self.fluent_requirements.setdefault(fact, []).append(exogenous)
                elif exogenous is None and fact in self.fluent_requirements:
                    # Also certified unconditionally now: it holds in every state.
                    self.fluent_requirements[fact].append(((), ()))
        return outputs

    def add_wild_facts(self, instance: StreamInstance) -> None:
        """Facts a call certified beyond the stream's :certified ones (wild outputs)."""
        wild = instance.take_wild_facts()
        if not wild:
            return
        self.saw_wild_facts = True
        result = StreamResult(instance.name, instance.inputs, (), tuple(wild), wild=True)
        for fact in wild:
            for name in fact[1:]:
                self.object_types.setdefault(name, OBJECT_TYPE)
            self.add_fact(fact, result)

    def exogenous_context(self, instance: StreamInstance) -> Context | None:
        """For a stream whose :domain has facts that actions change (PDDLStream's exogenous
        streams), the context in which what it certifies holds: those facts, instantiated
        with the instance's inputs. ``None`` for other streams."""
        external = instance.external
        if not isinstance(external, Stream) or not external.fluent_domain:
            return None
        mapping = dict(zip(external.inputs, instance.inputs, strict=True))
        return ((), tuple(instantiate_atoms(external.fluent_domain, mapping)))

    def search(self, init: Iterable[Fact], objects: Mapping[str, str],
               function_values: Mapping[Fact, float], max_expansions: int | None = None,
               context_blocks: Mapping[Fact, list[Context]] | None = None,
               budgeted: bool = False,
               guess: Sequence[tuple[str, tuple[str, ...]]] | None = None,
               skip_if_grounded_as: frozenset[object] | None = None) -> DiscreteResult:
        """One discrete search. ``budgeted``: bound it by :attr:`search_budget` expansions,
        doubled whenever a search runs out of it (``DiscreteResult.capped``): a search that
        fails is usually exhaustive, and the algorithms learn as much from a bounded failure
        (sample more, raise the complexity) at a fraction of the cost, while the growing
        budget keeps them complete. ``guess``: a candidate plan checked before searching
        (see :func:`.plan_discrete`, also for ``skip_if_grounded_as``)."""
        start = time.perf_counter()
        cpu_start = time.thread_time()
        self.searches += 1
        if budgeted:
            max_expansions = self.search_budget
        try:
            result = plan_discrete(
                self.problem.domain, objects, init, function_values, self.problem.goal,
                self.deadline, self.config.search, self.config.unit_costs, max_expansions,
                self.config.constraints, self.cost_bound, self.fluent_requirements,
                context_blocks, guess, skip_if_grounded_as,
                self.grounding_cache if self.config.incremental_grounding else None)
        finally:
            self.search_time += time.perf_counter() - start
            self.search_cpu += time.thread_time() - cpu_start
        self.grounding_time += result.ground_time_s
        self.work.add_search(len(init) if isinstance(init, Sized) else 0, result)
        if budgeted and result.capped and not result.skipped:
            self.search_budget *= 2
        return result

    def sampling_cpu(self) -> float:
        """CPU seconds of the stream calls so far (estimated per stream from a sample of
        timed calls, :class:`~ltamp_cli.planner.streams.StreamStats`)."""
        return sum(stats.cpu_s for stats in self.stream_stats.values())

    def remember_skeleton(self, actions: list[str]) -> None:
        """Keep the last optimistic plans, to explain a failure."""
        self.last_skeletons = [*self.last_skeletons, actions][-MAX_REMEMBERED_SKELETONS:]

    def diagnose(self, discrete: DiscreteResult, facts: Iterable[Fact]) -> None:
        """Record which goal atoms the last (optimistic) search could not even reach."""
        if discrete.solved:
            self.unreachable_goal = []
            return
        reachable = discrete.grounding.reachable
        self.unreachable_goal = [
            "(" + " ".join(atom) + ")" for atom in goal_atoms(self.problem)
            if atom not in reachable]

    def bindings_of(self, external: External, index: FactIndex,
                    since: Mapping[str, int] | None = None,
                    bound: CostBound | None = None) -> Iterator[tuple[str, ...]]:
        """Input tuples whose domain facts all hold in ``index``; with ``since`` (a
        :meth:`FactIndex.sizes` snapshot), only those using a fact added after it (possibly
        repeated) and within ``bound`` (see :func:`.join_tuples`)."""
        inputs = external_inputs(external)
        literals = [LiftedLiteral(a.predicate, a.args) for a in external_domain(external)]
        if not literals:
            if inputs:
                raise InputError(f"stream {external.name!r} has inputs but an empty :domain; "
                                 "every input must appear in a :domain fact")
            if since is None:
                yield ()
            return
        yield from join_tuples(literals, index, tuple(inputs), since, bound)

    def result(self, status: str, discrete: DiscreteResult | None,
               preimage: Iterable[Fact] = (), *, known_facts: bool = True) -> PlanResult:
        """The solve's result. ``known_facts=False``: the certificate lists no fact (the
        watchdog's result of an abandoned worker, built past the deadline while the worker
        may still hold the GIL: a list of 10^5 facts took it 0.5 s of wall under load)."""
        plan = None
        cost = float("inf")
        # Sorted for a plan; otherwise in discovery order (as deterministic, linear): a
        # timeout's result is built after the deadline, and sorting 10^5 facts takes seconds.
        if not known_facts:
            certificate = Certificate()
        elif status == SOLVED:
            certificate = Certificate(facts=sorted(self.facts.members))
        else:
            certificate = Certificate(facts=self.facts.in_discovery_order())
        if discrete is not None and discrete.actions is not None:
            plan = [PlanStep(a.name, a.args, tuple(self.objects.value(x) for x in a.args),
                             a.cost) for a in discrete.actions]
            cost = float(sum(step.cost for step in plan))
            used = sorted(set(preimage))
            certificate.preimage = used
            certificate.stream_results = self.supporting_results(used)
        if status != SOLVED:
            stats_calls = {name: self.stream_stats.get(name) for name in self.externals}
            diagnostics = {
                "unreachable_goal_facts": self.unreachable_goal,
                "streams_never_called": sorted(
                    n for n, s in stats_calls.items() if s is None or s.calls == 0),
                "streams_never_succeeded": sorted(
                    n for n, s in stats_calls.items()
                    if s is not None and s.calls > 0 and s.successes == 0),
                "last_skeletons": self.last_skeletons,
                "time_spent": self.time_spent(),
            }
        else:
            diagnostics = {}
        stats = {
            "algorithm": self.config.algorithm,
            "iterations": self.iterations,
            "searches": self.searches,
            # Seconds in discrete searches, of which grounding their tasks; in stream calls.
            "search_time_s": round(self.search_time, 6),
            "grounding_time_s": round(self.grounding_time, 6),
            "sampling_time_s": round(self.sampling_time, 6),
            "facts": len(self.facts.members),
            "streams": {name: s.as_dict() for name, s in sorted(self.stream_stats.items())},
            # Load-independent counts of the work done (see WorkCount).
            "work": asdict(self.work),
        }
        if self.parked.parked_total:
            stats["parked"] = self.parked.stats()
        return PlanResult(status, plan, cost, time.perf_counter() - self.start_time, stats,
                          certificate, {n: self.objects.value(n) for n in self.objects.names()},
                          diagnostics)


    def time_spent(self) -> dict[str, object]:
        """Where the solve's time went (seconds), to tell why it failed: grounding the
        searches' tasks, searching them, calling streams (per stream: calls, successes,
        seconds, slowest first), and the number of searches."""
        streams = sorted(self.stream_stats.items(), key=lambda item: -item[1].time_s)
        return {
            "total_s": round(time.perf_counter() - self.start_time, 6),
            "grounding_s": round(self.grounding_time, 6),
            "search_s": round(self.search_time - self.grounding_time, 6),
            "streams_s": round(self.sampling_time, 6),
            "searches": self.searches,
            "per_stream": {name: {"calls": s.calls, "successes": s.successes,
                                  "seconds": round(s.time_s, 6)} for name, s in streams},
        }

    def supporting_results(self, needed: Iterable[Fact]) -> list[StreamResult]:
        """Stream results behind ``needed`` facts, closed under the results' own domain facts
        (and the domains of cost functions used), dependencies first."""
        ordered: list[StreamResult] = []
        seen: set[StreamResult] = set()
        visiting: set[Fact] = set()
        for fact in needed:
            self._visit_support(fact, ordered, seen, visiting)
        return ordered

    def _domain_facts(self, name: str, inputs: tuple[str, ...]) -> list[Fact]:
        external = self.externals[name]
        mapping = dict(zip(external_inputs(external), inputs, strict=True))
        return instantiate_atoms(external_domain(external), mapping)

    def _visit_support(self, fact: Fact, ordered: list[StreamResult], seen: set[StreamResult],
                       visiting: set[Fact]) -> None:
        """Append the results behind ``fact`` to ``ordered``, dependencies first (a method,
        not a nested recursive function, which would form a reference cycle)."""
        if fact in visiting:
            return
        visiting.add(fact)
        if fact[0] in self.externals and isinstance(self.externals[fact[0]], StreamFunction):
            for domain_fact in self._domain_facts(fact[0], fact[1:]):
                self._visit_support(domain_fact, ordered, seen, visiting)
            return
        producer = self.producers.get(fact)
        if producer is None or producer in seen:
            return
        for domain_fact in self._domain_facts(producer.stream, producer.inputs):
            self._visit_support(domain_fact, ordered, seen, visiting)
        seen.add(producer)
        ordered.append(producer)


def bound_plan(actions: Iterable[tuple[str, tuple[str, ...]]], mapping: Mapping[str, str]
               ) -> list[tuple[str, tuple[str, ...]]]:
    """An optimistic plan (action names and arguments) with placeholders replaced by the
    values ``mapping`` bound them to."""
    return [(name, tuple(mapping.get(x, x) for x in args)) for name, args in actions]


def goal_atoms(problem: PlanningProblem) -> list[Fact]:
    """Ground atoms of the goal's top-level conjunction (the ones a user names)."""
    goal = problem.goal
    parts = goal.parts if isinstance(goal, And) else (goal,)
    return [(p.predicate, *p.args) for p in parts
            if isinstance(p, Atom) and not any(a.startswith("?") for a in p.args)]


class StreamError(Exception):
    """A stream binding raised: reported with the stream's name and inputs."""

    def __init__(self, instance: StreamInstance, error: BaseException) -> None:
        super().__init__(f"stream {instance.name!r} raised {type(error).__name__}: {error} "
                         f"(inputs {', '.join(instance.inputs)})")
        self.instance = instance


def initial_state(problem: PlanningProblem, config: PlannerConfig) -> PlannerState:
    """Objects, facts and bindings of a problem, ready for an algorithm."""
    objects = ObjectTable()
    for name, (_, value) in problem.objects.items():
        objects.add(name, value)
    externals: dict[str, External] = {}
    bindings: dict[str, Binding] = {}
    if problem.stream_file is not None and problem.streams_factory is not None:
        rng = np.random.default_rng(config.seed)
        try:
            provided = problem.streams_factory(dict(problem.world), rng)
        except (InputError, KeyboardInterrupt):
            raise
        except BaseException as error:  # user code, even SystemExit
            raise InputError(f"make_streams of {problem.bindings_source!r} failed: "
                             f"{type(error).__name__}: {error}") from None
        if not isinstance(provided, Mapping):
            raise InputError(f"make_streams of {problem.bindings_source!r} must return a "
                             "mapping of stream name to callable")
        bindings = resolve_bindings(problem.stream_file, provided, repr(problem.bindings_source))
        externals = {
            **{s.name: s for s in problem.stream_file.streams},
            **{f.name: f for f in problem.stream_file.functions},
            **{p.name: p for p in problem.stream_file.predicates},
        }
    state = PlannerState(problem, config, objects,
                         {name: type_name for name, (type_name, _) in problem.objects.items()},
                         externals, bindings)
    if config.algorithm == "incremental":
        state.search_budget = INITIAL_INCREMENTAL_EXPANSIONS
    if config.max_cost < float("inf"):
        state.cost_bound = config.max_cost  # every search then asks for a cheaper plan
    for atom in problem.init:
        state.add_fact((atom.predicate, *atom.args))
    for value in problem.function_values:
        state.function_values[(value.term.name, *value.term.args)] = value.value
    return state


__all__ = ["ALGORITHMS", "INFEASIBLE", "SOLVED", "TIMEOUT", "PlannerConfig",
           "PlannerState", "StreamError", "initial_state"]
