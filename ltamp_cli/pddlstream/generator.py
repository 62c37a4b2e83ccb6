"""PDDLStream's procedure wrappers (``from_gen_fn``, ``from_fn``, ...) and stream hints.

As in PDDLStream, every wrapper turns a procedure into a *list generator function*:
``fn(*inputs, **kwargs)`` returns an iterator whose items are lists of output tuples (an
empty list: nothing this call). Tests produce ``[()]`` when true and ``[]`` when false.
``kwargs`` carries ``fluents=[...]`` for streams declared with ``:fluents``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any

from ltamp_cli.planner.streams import WildOutput

ListGenFn = Callable[..., Iterator[list[Any]]]


def from_list_gen_fn(list_gen_fn: ListGenFn) -> ListGenFn:
    """A function returning an iterator of lists of outputs is already the right shape."""
    return list_gen_fn


def from_gen_fn(gen_fn: Callable[..., Iterable[Any]]) -> ListGenFn:
    """Each item the generator yields is one output tuple (``None``: nothing this call)."""
    def list_gen_fn(*inputs: Any, **kwargs: Any) -> Iterator[list[Any]]:
        return ([] if output is None else [output] for output in gen_fn(*inputs, **kwargs))
    return list_gen_fn


def from_sampler(sampler: Callable[..., Any], max_attempts: float = math.inf) -> ListGenFn:
    """Call ``sampler(*inputs)`` for each new output, at most ``max_attempts`` times."""
    def gen_fn(*inputs: Any, **kwargs: Any) -> Iterator[Any]:
        for _ in itertools.takewhile(lambda attempt: attempt < max_attempts, itertools.count()):
            yield sampler(*inputs, **kwargs)
    return from_gen_fn(gen_fn)


def from_list_fn(list_fn: Callable[..., list[Any]]) -> ListGenFn:
    """A function returning all of its outputs at once, as a list (called once)."""
    def list_gen_fn(*inputs: Any, **kwargs: Any) -> Iterator[list[Any]]:
        return iter([list_fn(*inputs, **kwargs)])
    return list_gen_fn


def from_fn(fn: Callable[..., Any]) -> ListGenFn:
    """A function returning one output tuple, or ``None`` when it has none (called once)."""
    def list_fn(*inputs: Any, **kwargs: Any) -> list[Any]:
        output = fn(*inputs, **kwargs)
        return [] if output is None else [output]
    return from_list_fn(list_fn)


def from_test(test: Callable[..., Any]) -> ListGenFn:
    """A boolean test as a stream without outputs. A ``WildOutput`` the test returns is
    passed on, not taken as ``True`` (its facts would be lost): the stream refuses it in one
    line, as for ``from_fn``."""
    def outputs(*inputs: Any, **kwargs: Any) -> Any:
        truth = test(*inputs, **kwargs)
        return truth if isinstance(truth, WildOutput) else (() if truth else None)
    return from_fn(outputs)


def fn_from_constant(constant: Any) -> Callable[..., Any]:
    """A function of any inputs that returns ``constant``."""
    return lambda *inputs, **kwargs: constant


def from_constant(constant: Any) -> ListGenFn:
    return from_fn(fn_from_constant(constant))


def negate_test(test: Callable[..., Any]) -> Callable[..., bool]:
    return lambda *inputs, **kwargs: not test(*inputs, **kwargs)


def from_gen(outputs: Iterable[Any]) -> ListGenFn:
    """The same outputs for any inputs."""
    return from_gen_fn(lambda *inputs, **kwargs: iter(outputs))


def empty_gen() -> ListGenFn:
    return from_gen([])


universe_test = fn_from_constant(True)
empty_test = fn_from_constant(False)


@dataclass(frozen=True)
class StreamInfo:
    """Hints for a stream, named as in PDDLStream.

    ``p_success`` (prior probability that a call yields an output), ``overhead`` (expected
    seconds per call), ``eager`` (evaluate as soon as inputs exist) and ``opt_gen_fn`` (a
    ``PartialInputs``: which inputs the optimistic outputs are shared over; any other
    callable: one placeholder per instance) steer ltamp's planner. The other fields are
    accepted so that scripts run unchanged, and ignored: ltamp neither defers streams
    (``defer_fn``) nor negates or batches them by these flags.
    """

    opt_gen_fn: Callable[..., Any] | None = None
    negate: bool = False
    simultaneous: bool = False
    verbose: bool = True
    p_success: float | None = None
    overhead: float | None = None
    eager: bool = False
    defer_fn: Callable[..., Any] | None = None
    use_unique: bool = False
    effort: float | None = None


@dataclass(frozen=True)
class FunctionInfo:
    """Hints for a ``:function``: ``p_success`` and ``overhead`` as for streams. ``opt_fn``
    (PDDLStream's optimistic value), ``eager``, ``verbose``, ``effort`` and ``defer_fn`` are
    accepted and ignored: ltamp's optimistic value of a function is 0."""

    opt_fn: Callable[..., Any] | None = None
    eager: bool = False
    verbose: bool = True
    p_success: float | None = None
    overhead: float | None = None
    effort: float | None = None
    defer_fn: Callable[..., Any] | None = None


PredicateInfo = FunctionInfo


@dataclass(frozen=True)
class UniqueOptValue:
    """PDDLStream's optimistic value of one stream instance's output. ltamp never passes
    optimistic values to user procedures (a function's optimistic value is 0), so user code
    only ever sees real values; the type exists so that ported ``isinstance`` checks run."""

    instance: Any
    sequence_index: int
    output: str


@dataclass(frozen=True)
class SharedOptValue:
    """PDDLStream's optimistic value shared by a stream's instances (see
    :class:`UniqueOptValue`)."""

    stream: str
    inputs: tuple[Any, ...]
    input_objects: tuple[Any, ...]
    output: str


def add_opt_function(name: str, base_fn: Callable[..., float], stream_map: dict[str, Any],
                     stream_info: dict[str, Any], constant: float = 0.0,
                     coefficient: float = 1.0, **info_options: Any
                     ) -> tuple[dict[str, Any], dict[str, Any]]:
    """Bind the ``:function`` ``name`` to ``constant + coefficient * base_fn(...)`` and give it
    a :class:`FunctionInfo` whose ``opt_fn`` is ``constant`` (PDDLStream's helper). The
    updated ``(stream_map, stream_info)`` are returned (the given dicts, changed in place)."""
    stream_map[name] = lambda *args, **kwargs: constant + coefficient * base_fn(*args, **kwargs)
    stream_info[name] = FunctionInfo(opt_fn=fn_from_constant(constant), **info_options)
    return stream_map, stream_info



def outputs_from_boolean(boolean: Any) -> tuple[()] | None:
    """A test's truth as one empty output tuple (true) or no output (false)."""
    return () if boolean else None


# PDDLStream's deferral policies (``StreamInfo(defer_fn=...)``). ltamp never defers a stream
# call past planning, so these are accepted and have no effect.
def never_defer(*_args: Any, **_kwargs: Any) -> bool:
    return False


def defer_unique(*_args: Any, **_kwargs: Any) -> bool:
    return False


def defer_shared(*_args: Any, **_kwargs: Any) -> bool:
    return False


def get_defer_all_unbound(inputs: str = "") -> Callable[..., bool]:
    return never_defer


def get_defer_any_unbound() -> Callable[..., bool]:
    return never_defer


__all__ = ["FunctionInfo", "PredicateInfo", "SharedOptValue", "StreamInfo", "UniqueOptValue",
           "add_opt_function", "defer_shared", "defer_unique",
           "empty_gen", "empty_test", "fn_from_constant", "from_constant", "from_fn", "from_gen",
           "from_gen_fn", "from_list_fn", "from_list_gen_fn", "from_sampler", "from_test",
           "get_defer_all_unbound", "get_defer_any_unbound", "negate_test", "never_defer",
           "outputs_from_boolean", "universe_test"]
