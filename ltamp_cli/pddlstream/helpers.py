"""General helpers that PDDLStream scripts import from ``pddlstream.utils`` and a few other
``pddlstream.*`` modules, so that those scripts run unmodified under
:mod:`ltamp_cli.pddlstream.alias`.

These are small, planner-independent utilities (written for ltamp from their documented
behaviour): sequence helpers, a profiler context manager, plan re-timing. None of them is
used by ltamp itself, none keeps state between calls, and none writes a file unless the
script asks for it (``ensure_dir``, ``safe_rm_dir``).
"""

from __future__ import annotations

import cProfile
import itertools
import math
import pstats
import random
import shutil
import time
from collections import defaultdict
from collections.abc import Callable, Hashable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any, NamedTuple, TypeVar

from ltamp_cli.pddlstream.language import MINIMIZE, PDDLText, get_file_path, get_prefix, read

T = TypeVar("T")

INF = math.inf
SEPARATOR = "\n" + 80 * "-" + "\n"
# PDDLStream's folder for its plan visualisations (a relative path, never created here).
VISUALIZATIONS_DIR = "visualizations/"
# PDDLStream caps costs at Fast Downward's integer limit; ltamp has no such cap, the number
# is kept for scripts that derive their own bounds from it.
MAX_FD_COST = 1e8

user_input = input
inf_generator = itertools.count


def elapsed_time(start_time: float) -> float:
    """Seconds of wall time since ``start_time`` (a ``time.time()`` value)."""
    return time.time() - start_time


def safe_zip(first: Sequence[Any], second: Sequence[Any]) -> Iterator[tuple[Any, Any]]:
    """``zip`` of two sequences that must have the same length (else ``ValueError``)."""
    if len(first) != len(second):
        raise ValueError(f"safe_zip: lengths differ ({len(first)} and {len(second)})")
    return zip(first, second, strict=True)


def get_mapping(keys: Sequence[Any], values: Sequence[Any]) -> dict[Any, Any]:
    """``dict`` pairing two sequences of equal length."""
    return dict(safe_zip(keys, values))


def apply_mapping(sequence: Iterable[Any], mapping: Mapping[Any, Any]) -> tuple[Any, ...]:
    """Each element replaced by its image under ``mapping`` when it has one."""
    return tuple(mapping.get(item, item) for item in sequence)


def safe_apply_mapping(sequence: Iterable[Any], mapping: Mapping[Any, Any]) -> tuple[Any, ...]:
    """Each element replaced by its image under ``mapping`` (``KeyError`` if it has none)."""
    return tuple(mapping[item] for item in sequence)


def negate_test(test: Callable[..., Any]) -> Callable[..., bool]:
    """A predicate that is true exactly where ``test`` is false."""
    def negated(*args: Any, **kwargs: Any) -> bool:
        return not test(*args, **kwargs)
    return negated


def flatten(nested: Iterable[Iterable[T]]) -> Iterator[T]:
    """The items of each iterable in turn (one level, lazily)."""
    return itertools.chain.from_iterable(nested)


def find(test: Callable[[T], Any], sequence: Iterable[T]) -> T | None:
    """The first item passing ``test``, or ``None``."""
    return next((item for item in sequence if test(item)), None)


def find_unique(test: Callable[[T], Any], sequence: Iterable[T]) -> T:
    """The one item passing ``test``; ``RuntimeError`` if none or several do."""
    matches = [item for item in sequence if test(item)]
    if len(matches) != 1:
        raise RuntimeError(f"find_unique: {len(matches)} items pass the test, expected 1")
    return matches[0]


def implies(a: Any, b: Any) -> bool:
    """Logical implication ``a -> b``."""
    return bool(not a or b)


def irange(start: float, end: float | None = None, step: float = 1) -> Iterator[float]:
    """``start, start + step, ...`` below ``end`` (one argument: from 0 below it); unlike
    ``range`` the numbers may be floats and ``end`` may be ``INF``."""
    if end is None:
        start, end = 0, start
    value = start
    while value < end:
        yield value
        value += step


def argmin(fn: Callable[[T], Any], iterable: Iterable[T]) -> T:
    return min(iterable, key=fn)


def argmax(fn: Callable[[T], Any], iterable: Iterable[T]) -> T:
    return max(iterable, key=fn)


def invert_dict(mapping: Mapping[Any, Any]) -> dict[Any, Any]:
    return {value: key for key, value in mapping.items()}


def randomize(iterable: Iterable[T]) -> list[T]:
    """A list of the items in random order (Python's global ``random``, as PDDLStream)."""
    items = list(iterable)
    random.shuffle(items)
    return items


def clip(value: float, lower: float = -INF, upper: float = INF) -> float:
    return min(max(lower, value), upper)


def lowercase(*strings: str) -> list[str]:
    return [string.lower() for string in strings]


def str_eq(first: str, second: str, ignore_case: bool = True) -> bool:
    """String equality, case-insensitive by default (PDDL names are)."""
    if ignore_case:
        return first.lower() == second.lower()
    return first == second


def is_hashable(value: Any) -> bool:
    return isinstance(value, Hashable) and _hashes(value)


def _hashes(value: Any) -> bool:
    try:
        hash(value)
    except TypeError:  # e.g. a tuple holding a list
        return False
    return True


def value_or_id(value: Any) -> Any:
    """The value itself when hashable, else its ``id``."""
    return value if is_hashable(value) else id(value)


def read_pddl(this_file: str, pddl_filename: str) -> PDDLText:
    """The PDDL file ``pddl_filename`` next to the script ``this_file``."""
    return read(get_file_path(this_file, pddl_filename))


def ensure_dir(path: str) -> None:
    """Create the folder part of ``path`` (``"out/plan.txt"`` creates ``out/``)."""
    folder = Path(path).parent if not str(path).endswith(("/", "\\")) else Path(path)
    folder.mkdir(parents=True, exist_ok=True)


def safe_rm_dir(path: str) -> None:
    """Remove the folder ``path`` and its contents if it exists."""
    if Path(path).exists():
        shutil.rmtree(path)


def str_from_object(obj: Any, ndigits: int | None = None) -> str:
    """A deterministic text for nested lists, tuples, dicts and sets (dict keys and set
    items sorted by their text); floats rounded to ``ndigits`` when given."""
    if isinstance(obj, list):
        return "[" + ", ".join(str_from_object(item, ndigits) for item in obj) + "]"
    if isinstance(obj, tuple) and not hasattr(obj, "_fields"):
        return "(" + ", ".join(str_from_object(item, ndigits) for item in obj) + ")"
    if isinstance(obj, dict):
        keys = sorted(obj, key=lambda key: str_from_object(key, ndigits))
        return "{" + ", ".join(f"{str_from_object(key, ndigits)}: "
                               f"{str_from_object(obj[key], ndigits)}" for key in keys) + "}"
    if isinstance(obj, set | frozenset):
        return "{" + ", ".join(sorted(str_from_object(item, ndigits) for item in obj)) + "}"
    if ndigits is not None and isinstance(obj, float):
        rounded = round(float(obj), ndigits) + 0.0  # + 0.0 turns -0.0 into 0.0
        return f"{rounded:.{ndigits}f}"
    return str(obj)


def sorted_str_from_list(obj: Iterable[Any], ndigits: int | None = None) -> str:
    return "[" + ", ".join(sorted(str_from_object(item, ndigits) for item in obj)) + "]"


def incoming_from_edges(edges: Iterable[tuple[Any, Any]]) -> dict[Any, set[Any]]:
    incoming: dict[Any, set[Any]] = defaultdict(set)
    for source, target in edges:
        incoming[target].add(source)
    return incoming


def outgoing_from_edges(edges: Iterable[tuple[Any, Any]]) -> dict[Any, set[Any]]:
    outgoing: dict[Any, set[Any]] = defaultdict(set)
    for source, target in edges:
        outgoing[source].add(target)
    return outgoing


def neighbors_from_orders(orders: Iterable[tuple[Any, Any]]
                          ) -> tuple[dict[Any, set[Any]], dict[Any, set[Any]]]:
    """``(incoming, outgoing)`` neighbour sets of a list of ``(before, after)`` pairs."""
    pairs = list(orders)
    return incoming_from_edges(pairs), outgoing_from_edges(pairs)


class Profiler:
    """Profile the ``with`` block with :mod:`cProfile` and print the ``num`` most costly
    functions sorted by ``field`` (``"tottime"`` or ``"cumtime"``) on leaving it;
    ``num=None`` prints nothing."""

    FIELDS = ("tottime", "cumtime")

    def __init__(self, field: str = "tottime", num: int | None = 10) -> None:
        if field not in self.FIELDS:
            raise ValueError(f"Profiler: field must be one of {self.FIELDS}, got {field!r}")
        self.field = field
        self.num = num
        self.profile = cProfile.Profile()

    def __enter__(self) -> Profiler:
        self.profile.enable()
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self.profile.disable()
        if self.num is not None:
            pstats.Stats(self.profile).sort_stats(self.field).print_stats(self.num)


# pddlstream.language.constants


def is_cost(objective: Any) -> bool:
    """Whether a satisfaction term is an objective (``Minimize(...)``)."""
    return get_prefix(objective) == MINIMIZE


def get_constraints(objectives: Iterable[Any]) -> list[Any]:
    """The terms of a satisfaction problem that are constraints, not ``Minimize`` costs."""
    return [term for term in objectives if not is_cost(term)]


def get_parameter_name(expression: Any) -> Any:
    """``"?x"`` -> ``"x"``; anything else unchanged."""
    if isinstance(expression, str) and expression.startswith("?"):
        return expression[1:]
    return expression


# pddlstream.algorithms.downward


def set_cost_scale(scale: float) -> None:
    """Accepted for scripts that call it; ltamp plans with costs as given (no integer
    scaling for Fast Downward), so ``get_cost_scale()`` stays 1 and this has no effect."""
    if not (isinstance(scale, int | float) and scale > 0):
        raise ValueError(f"set_cost_scale: expected a positive number, got {scale!r:.40}")


# pddlstream.language.temporal: a sequential plan as timed steps


class DurativeAction(NamedTuple):
    """A plan step with a ``start`` time and a ``duration`` (same unit as given)."""

    name: str
    args: tuple[Any, ...]
    start: float
    duration: float


def retime_plan(plan: Sequence[Any] | None, duration: float = 1) -> list[DurativeAction] | None:
    """Step ``i`` of a sequential plan of ``(name, args)`` steps starts at ``i * duration``
    and lasts ``duration``; ``None`` (no plan) stays ``None``."""
    if plan is None:
        return None
    return [DurativeAction(name, tuple(args), index * duration, duration)
            for index, (name, args, *_) in enumerate(plan)]


def get_start(action: DurativeAction) -> float:
    return action.start


def get_end(action: DurativeAction) -> float:
    return action.start + action.duration


def compute_start(plan: Sequence[DurativeAction]) -> float:
    return min((action.start for action in plan), default=0.0)


def compute_end(plan: Sequence[DurativeAction]) -> float:
    return max((get_end(action) for action in plan), default=0.0)


def compute_duration(plan: Sequence[DurativeAction]) -> float:
    """Time from the first step's start to the last step's end (0 for an empty plan)."""
    return compute_end(plan) - compute_start(plan)


__all__ = [
    "INF", "MAX_FD_COST", "SEPARATOR", "VISUALIZATIONS_DIR", "DurativeAction", "Profiler",
    "apply_mapping", "argmax", "argmin", "clip", "compute_duration", "compute_end",
    "compute_start", "elapsed_time", "ensure_dir", "find", "find_unique", "flatten",
    "get_constraints", "get_end", "get_file_path", "get_mapping", "get_parameter_name",
    "get_start", "implies", "incoming_from_edges", "inf_generator", "invert_dict", "irange",
    "is_cost", "is_hashable", "lowercase", "negate_test", "neighbors_from_orders",
    "outgoing_from_edges", "randomize", "read", "read_pddl", "retime_plan", "safe_apply_mapping",
    "safe_rm_dir", "safe_zip", "set_cost_scale", "sorted_str_from_list", "str_eq",
    "str_from_object", "user_input",
]
