"""Objects of one planning run: PDDL names for (possibly continuous) Python values.

Values that compare equal (and are hashable, or are numpy arrays with the same bytes) get
the same object, so a stream that outputs an existing value does not create a new one.
Each :class:`ObjectTable` is private to one planner run.
"""

from __future__ import annotations

import numbers
from collections.abc import Hashable, Mapping
from typing import Any

import numpy as np


def value_key(value: Any) -> Hashable:
    """What identifies a value as an object: contents for arrays and containers, the value
    for numbers (any type: ``1 == 1.0 == np.int64(1)`` is one object, as in PDDLStream),
    identity for other unhashable values."""
    if isinstance(value, np.ndarray):
        return ("ndarray", value.dtype.str, value.shape, value.tobytes())
    if isinstance(value, list | tuple):
        return (type(value).__name__, tuple(value_key(v) for v in value))
    if isinstance(value, dict):
        return ("dict", tuple(sorted((str(k), value_key(v)) for k, v in value.items())))
    if isinstance(value, numbers.Number | np.bool_):
        # as PDDLStream (objects keyed by hash and ==): np.float64(2.0), 2.0, 2 are one
        # object; a stream's numpy output then matches the goal's Python literal
        try:
            hash(value)
        except TypeError:
            return ("id", id(value))
        return ("number", value)
    if isinstance(value, str | type(None)):
        return (type(value).__name__, value)
    try:
        hash(value)
    except TypeError:
        return ("id", id(value))
    return (type(value).__name__, value)


class ObjectTable:
    def __init__(self) -> None:
        self._values: dict[str, Any] = {}
        self._by_key: dict[Hashable, str] = {}
        self._counter = 0
        # Created object -> its creation rank (problem objects have none).
        self._rank: dict[str, int] = {}

    def add(self, name: str, value: Any) -> None:
        """Register a named object (from the problem file)."""
        self._values[name] = value
        if value is not None:
            self._by_key.setdefault(value_key(value), name)

    def intern(self, value: Any, prefix: str = "v") -> str:
        """The object for ``value``, created as ``@{prefix}{n}`` if new."""
        key = value_key(value)
        name = self._by_key.get(key)
        if name is None:
            name = f"@{prefix}{self._counter}"
            self._rank[name] = self._counter
            self._counter += 1
            self._by_key[key] = name
            self._values[name] = value
        return name

    @property
    def ranks(self) -> Mapping[str, int]:
        """Created object -> creation rank (0 first); problem objects are absent."""
        return self._rank

    def value(self, name: str) -> Any:
        """The Python value of an object; symbolic objects are their own name."""
        value = self._values.get(name)
        return name if value is None else value

    def __contains__(self, name: str) -> bool:
        return name in self._values

    def names(self) -> list[str]:
        return list(self._values)
