"""Binding stream declarations to Python, and the run-time state of stream instances.

A binding module provides a factory::

    def make_streams(world: Mapping[str, Any], rng: numpy.random.Generator
                     ) -> Mapping[str, Callable | Binding]

mapping every name of the stream file (streams, ``:function`` and ``:predicate``) to Python.
The declaration decides how a plain callable is used:

* a stream with outputs: ``fn(*inputs)`` returns a generator/iterable (each ``next()`` gives
  one output tuple, or a list of output tuples — possibly empty, meaning "nothing this call"),
  or a single output tuple / ``None`` (a single-shot function);
* a stream without outputs (a test) and a ``:predicate``: ``fn(*inputs) -> bool``;
* a ``:function``: ``fn(*inputs) -> float`` (an action cost).

A stream declared with ``:fluents (P ...)`` is also given ``fluents=[(P, *values), ...]``: the
facts of those predicates in the state where its output is used (e.g. obstacle poses for a
motion planner). Its certified facts then hold only in states that contain those facts: the
planner adds them as preconditions of every action that relies on the output.

Wrap a callable in :class:`Binding` to give per-stream :class:`StreamInfo`.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ltamp_cli.errors import InputError
from ltamp_cli.planner.objects import ObjectTable
from ltamp_cli.planner.pddl.syntax import (
    ExternalPredicate,
    Stream,
    StreamFile,
    StreamFunction,
)


@dataclass(frozen=True)
class PartialInputs:
    """Which inputs a stream's optimistic outputs depend on (PDDLStream's ``PartialInputs``).

    The focused, binding and adaptive algorithms give the instances of a stream
    placeholder outputs. ``PartialInputs()`` (``inputs=""``): every instance of the stream
    shares one placeholder per output, so the optimistic task does not grow with the number
    of instances; ``inputs="?o"`` shares one per value of ``?o``; ``unique=True`` (or
    naming every input) gives each instance its own. Without a policy
    (``StreamInfo.opt_gen_fn=None``, the default) the instances over real values only, and
    all instances of a stream whose outputs never reach a fact that actions change, keep
    their own; the other instances share one with those that have the same placeholder
    inputs (PDDLStream's ``PartialInputs`` over the inputs holding placeholders; see
    :mod:`ltamp_cli.planner.algorithms.optimistic`).
    A plan that needs a shared placeholder from two instances is refined before it is bound
    (see :mod:`ltamp_cli.planner.algorithms.optimistic`). ``inputs``: space-separated input
    parameters of the stream, e.g. ``"?o ?r"``.
    """

    inputs: str = ""
    unique: bool = False

    def selected(self, stream_inputs: tuple[str, ...]) -> tuple[int, ...] | None:
        """Positions of the inputs the shared outputs depend on; ``None``: unique outputs
        (``unique`` or every input selected)."""
        names = [name.lower() for name in self.inputs.split()]
        if self.unique or set(names) >= set(stream_inputs):
            return None
        return tuple(i for i, name in enumerate(stream_inputs) if name in names)


@dataclass(frozen=True)
class StreamInfo:
    """Planner hints for a stream (PDDLStream's ``StreamInfo``).

    ``p_success``: prior probability a call yields a usable output; ``overhead``: expected
    seconds per call (both order stream plans); ``eager``: call as soon as inputs exist
    (cheap tests); ``opt_cost``: optimistic lower bound of a ``:function``;
    ``opt_gen_fn``: which inputs the stream's optimistic outputs depend on
    (:class:`PartialInputs`; ``None``: shared by the instances with the same placeholder
    inputs).
    """

    p_success: float = 1.0
    overhead: float = 1.0
    eager: bool = False
    opt_cost: float = 0.0
    opt_gen_fn: PartialInputs | None = None


@dataclass(frozen=True)
class Binding:
    """A stream's Python function plus planner hints.

    ``on_unusable(inputs, outputs)``, if given, is called with the input values and one
    output tuple of this stream when the planner found that output could not be extended
    to a plan (a stream that consumed it failed). Learned samplers use it to steer later
    samples away (the diverse sampler's kernel learning).
    """

    function: Callable[..., Any]
    info: StreamInfo = field(default_factory=StreamInfo)
    on_unusable: Callable[[tuple[Any, ...], tuple[Any, ...]], None] | None = None


External = Stream | StreamFunction | ExternalPredicate


def _always_true(*_inputs: Any, **_fluents: Any) -> bool:
    return True


# A rule is an always-true test evaluated as soon as its inputs exist (PDDLStream's rules).
RULE_BINDING = Binding(_always_true, StreamInfo(p_success=1.0, overhead=0.0, eager=True))


def _by_lower_name(provided: Mapping[str, Any], source: str) -> dict[str, Any]:
    """``provided`` keyed by lower-cased names (PDDL names are case-insensitive)."""
    lowered: dict[str, Any] = {}
    originals: dict[str, str] = {}
    for key, value in provided.items():
        name = str(key).lower()
        if name in lowered:
            raise InputError(f"{source} binds both {originals[name]!r} and {key!r}: PDDL names "
                             "are case-insensitive, so they name the same stream")
        lowered[name] = value
        originals[name] = str(key)
    return lowered


def resolve_bindings(stream_file: StreamFile, provided: Mapping[str, Any], source: str
                     ) -> dict[str, Binding]:
    """Check that every declared stream has a binding; normalise to :class:`Binding`.

    Names match case-insensitively; rules need no binding. A missing or unusable binding is
    reported at the declaration in the stream file.
    """
    lowered = _by_lower_name(provided, source)
    bindings: dict[str, Binding] = {}
    externals: list[External] = [*stream_file.streams, *stream_file.functions,
                                 *stream_file.predicates]
    negated: list[Stream | ExternalPredicate] = []
    for external in externals:
        name = external.name
        if isinstance(external, Stream) and external.is_rule:
            bindings[name] = RULE_BINDING
            continue
        if isinstance(external, Stream | ExternalPredicate) and external.negates:
            negated.append(external)  # bound below, from the binding of the test it negates
            continue
        kind = ("stream" if isinstance(external, Stream) else
                "function" if isinstance(external, StreamFunction) else "predicate")
        if name not in lowered:
            raise InputError(
                f"{kind} {name!r} has no Python binding: {source} provides "
                f"{', '.join(sorted(map(str, provided))) or 'nothing'}", external.location)
        value = lowered[name]
        if isinstance(value, Binding):
            bindings[name] = value
        elif callable(value):
            bindings[name] = Binding(value)
        else:
            raise InputError(f"the binding of {kind} {name!r} in {source} is not callable",
                             external.location)
        policy = bindings[name].info.opt_gen_fn
        if isinstance(external, Stream) and policy is not None:
            unknown = [name for name in policy.inputs.split()
                       if name.lower() not in external.inputs]
            if unknown:
                raise InputError(
                    f"StreamInfo(opt_gen_fn=PartialInputs({' '.join(unknown)!r})) of stream "
                    f"{name!r} in {source} names no input of it (inputs: "
                    f"{' '.join(external.inputs) or 'none'})", external.location)
        returns_value = not isinstance(external, Stream) or external.is_test
        function = bindings[name].function
        if returns_value and (inspect.isgeneratorfunction(function)
                              or inspect.iscoroutinefunction(function)):
            what = "function" if isinstance(external, StreamFunction) else "test"
            raise InputError(f"the binding of {kind} {name!r} in {source} is a generator: a "
                             f"{what} returns its value (return, not yield)", external.location)
        if isinstance(external, Stream) and not external.certified:
            # It certifies only what its calls yield (wild facts), which no optimistic plan
            # can anticipate: call it as soon as its inputs exist, like PDDLStream's
            # incremental algorithm would.
            bindings[name] = replace(bindings[name], info=replace(bindings[name].info,
                                                                  eager=True))
    for external in negated:
        bindings[external.name] = negated_binding(bindings[external.negates], external.negates)
    return bindings


def negated_binding(binding: Binding, name: str) -> Binding:
    """The binding of a negated test (:mod:`ltamp_cli.planner.pddl.negation`): true exactly
    when ``binding``'s test returns false; the same overhead, the opposite success prior."""
    test = binding.function

    def negated(*inputs: Any, **fluents: Any) -> bool:
        return not _truth_value(name, test(*inputs, **fluents))

    info = binding.info
    p_success = min(max(1.0 - info.p_success, 0.01), 0.99)
    return Binding(negated, replace(info, p_success=p_success, opt_gen_fn=None))


@dataclass(frozen=True)
class WildOutput:
    """What one call of a stream produced, including facts it certifies beyond its
    ``:certified`` ones (PDDLStream's wild streams).

    ``values``: output tuples (for a test: ``[()]`` when true); ``facts``: tuples
    ``(predicate, value, ...)`` whose arguments are Python values like the outputs';
    ``enumerated``: the stream has nothing more for these inputs.
    """

    values: tuple[tuple[Any, ...], ...] = ()
    facts: tuple[tuple[Any, ...], ...] = ()
    enumerated: bool = False


# CPU time of a stream's calls is measured for its first CPU_TIMED_FIRST_CALLS calls and
# then for every CPU_TIMING_STRIDE-th call.
CPU_TIMED_FIRST_CALLS = 8
CPU_TIMING_STRIDE = 16


@dataclass
class StreamStats:
    calls: int = 0
    successes: int = 0
    outputs: int = 0
    time_s: float = 0.0  # wall seconds in the binding
    # CPU seconds of this thread in the binding: what decides in-run "cheap" (auto-eager),
    # because wall time on a loaded machine would make that decision, and so the run,
    # depend on the load. Measured for the first calls and then every CPU_TIMING_STRIDE-th
    # one; the others are counted at the measured mean (see :meth:`StreamInstance.call`).
    cpu_s: float = 0.0
    cpu_timed_calls: int = 0

    def as_dict(self) -> dict[str, float]:
        return {"calls": self.calls, "successes": self.successes, "outputs": self.outputs,
                "time_s": round(self.time_s, 6)}


# Iterators of Python sequences: their ``__length_hint__`` is exact.
FINITE_ITERATORS = (type(iter([])), type(iter(())))


class StreamInstance:
    """A stream applied to concrete input objects; called repeatedly for more outputs."""

    def __init__(self, external: External, binding: Binding, inputs: tuple[str, ...],
                 fluent_facts: tuple[tuple[str, ...], ...] = ()) -> None:
        self.external = external
        self.binding = binding
        self.inputs = inputs
        # For a stream with :fluents, the state facts it is called under (object names).
        self.fluent_facts = fluent_facts
        self.num_calls = 0
        self.exhausted = False
        self.disabled = False
        self.results: list[tuple[str, ...]] = []  # output object names, one tuple per output
        # Facts certified beyond :certified by the calls so far (wild outputs; object
        # names), until the planner takes them (:meth:`take_wild_facts`).
        self.wild_facts: list[tuple[str, ...]] = []
        self._iterator: Iterator[Any] | None = None
        self._function = False  # the binding returned a list's iterator (see _next)
        self.value: Any = None  # test / predicate truth or function value once evaluated

    @property
    def name(self) -> str:
        return self.external.name

    @property
    def is_test(self) -> bool:
        return not isinstance(self.external, Stream) or self.external.is_test

    def call(self, objects: ObjectTable, stats: StreamStats,
             cpu_clock: Callable[[], float] | None = None) -> list[tuple[str, ...]]:
        """Call once more; returns the *new* output tuples (object names). ``cpu_clock``
        (seconds) times the call's CPU for ``stats.cpu_s`` (default: this thread's CPU
        clock, ``time.thread_time``)."""
        import time

        clock = time.thread_time if cpu_clock is None else cpu_clock

        if self.exhausted:
            return []
        values = [objects.value(name) for name in self.inputs]
        # Reading the thread's CPU clock is a system call (~2-4 us of wall time here, as
        # much as a cheap sampler's call): time a sample of the calls, not all of them.
        timed = (stats.cpu_timed_calls < CPU_TIMED_FIRST_CALLS
                 or stats.calls % CPU_TIMING_STRIDE == 0)
        start = time.perf_counter()
        cpu_start = clock() if timed else 0.0
        self.num_calls += 1
        stats.calls += 1
        try:
            new = self._next(values, objects)
        finally:
            stats.time_s += time.perf_counter() - start
            if timed:
                stats.cpu_s += clock() - cpu_start
                stats.cpu_timed_calls += 1
            else:  # counted at the mean of the calls so far
                stats.cpu_s += stats.cpu_s / (stats.calls - 1)
        if new or (self.is_test and self.value):
            stats.successes += 1
        stats.outputs += len(new)
        self.results.extend(new)
        return new

    def _next(self, values: list[Any], objects: ObjectTable) -> list[tuple[str, ...]]:
        external = self.external
        if not isinstance(external, Stream) or external.is_test:
            if isinstance(external, Stream) and external.fluents:
                self.value = self.binding.function(*values,
                                                   fluents=self._fluent_values(objects))
            else:
                self.value = self.binding.function(*values)
            if isinstance(self.value, WildOutput):
                self._record_wild(self.value, objects)
                self.value = bool(self.value.values)
            self.exhausted = True
            if isinstance(external, StreamFunction):
                self.value = _cost_value(self.name, self.value)
            else:
                self.value = _truth_value(self.name, self.value)
            return []
        if self._iterator is None:
            if external.fluents:
                produced = self.binding.function(*values, fluents=self._fluent_values(objects))
            else:
                produced = self.binding.function(*values)
            if produced is None:
                self.exhausted = True
                return []
            if isinstance(produced, tuple) or not (
                inspect.isgenerator(produced) or isinstance(produced, Iterator)
                or (isinstance(produced, Sequence) and not isinstance(produced, str))
            ):
                self.exhausted = True
                return self._outputs([produced], objects)
            self._function = type(produced) in FINITE_ITERATORS
            self._iterator = iter(produced)
        try:
            item = next(self._iterator)
        except StopIteration:
            self.exhausted = True
            return []
        if isinstance(item, WildOutput):
            self._record_wild(item, objects)
            self.exhausted = self.exhausted or item.enumerated
            return self._outputs(list(item.values), objects)
        # The iterator of a list knows it has nothing left (``ltamp_cli.pddlstream``'s
        # ``from_fn``/``from_list_fn`` return one over one batch): the instance is a
        # function, exhausted by its first call, as PDDLStream bounds them. A generator's
        # length is unknown (it says so at its end); a list returned by a binding keeps
        # the behaviour of before (one more call to find its end).
        if self._function and not self._iterator.__length_hint__():  # type: ignore[attr-defined]
            self.exhausted = True
        batch = item if isinstance(item, list) else [item]
        return self._outputs(batch, objects)

    def _record_wild(self, produced: WildOutput, objects: ObjectTable) -> None:
        self.wild_facts.extend(_wild_fact(self.external, fact, objects)
                               for fact in produced.facts)

    def take_wild_facts(self) -> list[tuple[str, ...]]:
        """The wild facts certified since the last time they were taken."""
        taken, self.wild_facts = self.wild_facts, []
        return taken

    def _fluent_values(self, objects: ObjectTable) -> list[tuple[Any, ...]]:
        """The state facts of a ``:fluents`` stream, with Python values as arguments."""
        return [(fact[0], *(objects.value(a) for a in fact[1:])) for fact in self.fluent_facts]

    def _outputs(self, batch: list[Any], objects: ObjectTable) -> list[tuple[str, ...]]:
        assert isinstance(self.external, Stream)
        arity = len(self.external.outputs)
        outputs = []
        for output in batch:
            if output is None:
                continue
            if not isinstance(output, tuple) or len(output) != arity:
                raise InputError(
                    f"stream {self.name!r} must produce tuples of {arity} value(s) "
                    f"(one per output {' '.join(self.external.outputs)}), got {output!r:.80}",
                    self.external.location)
            outputs.append(tuple(
                objects.intern(value, variable[1:])
                for value, variable in zip(output, self.external.outputs, strict=True)))
        return outputs


def _wild_fact(stream: External, fact: Any, objects: ObjectTable) -> tuple[str, ...]:
    """A wild fact ``(predicate, value, ...)`` as a fact over object names."""
    if not isinstance(fact, tuple | list) or not fact or not isinstance(fact[0], str):
        raise InputError(f"stream {stream.name!r} certified {fact!r:.80}: a wild fact must be "
                         "a tuple (predicate, value, ...)", stream.location)
    return (fact[0].lower(), *(_object_name(value, objects) for value in fact[1:]))


def _object_name(value: Any, objects: ObjectTable) -> str:
    """A symbolic object given by its name stays that object; other values are interned."""
    if isinstance(value, str) and value in objects and objects.value(value) == value:
        return value
    return objects.intern(value)


def _cost_value(name: str, value: Any) -> float:
    """A ``:function``'s result as an action cost: a finite number ``>= 0``."""
    try:
        cost = float(value)
    except (TypeError, ValueError):
        raise InputError(f"function {name!r} must return a number (an action cost), "
                         f"got {value!r:.80}") from None
    if not math.isfinite(cost) or cost < 0.0:
        raise InputError(f"function {name!r} returned cost {cost}: action costs must be "
                         "finite and >= 0")
    return cost


def _truth_value(name: str, value: Any) -> bool:
    """A test stream's or ``:predicate``'s result; a generator is a mistake, not ``True``."""
    if inspect.isgenerator(value) or isinstance(value, Iterator | Sequence | Mapping) \
            or inspect.isawaitable(value):
        raise InputError(f"test {name!r} must return a bool, got {type(value).__name__} "
                         "(a test has no outputs: return, don't yield)")
    return bool(value)


def seeded_rng(seed: int | None) -> np.random.Generator:
    return np.random.default_rng(seed)
