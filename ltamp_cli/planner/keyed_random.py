"""Random generators keyed by what a stream is asked: common random numbers for bindings.

A bindings module gets one ``numpy.random.Generator`` from ``make_streams(world, rng)``. If
every sampler draws from it, a stream's outputs depend on how many draws every *other* stream
made before it: a different learned model for one skill, a planner change or another order of
calls reshuffles the samples of all the rest, so two runs of one seed cannot be compared
stream by stream, and a paired benchmark (model A against model B, seed by seed) measures
mostly that reshuffle.

:class:`KeyedRandom` derives, from one draw of the solve's generator, a fresh generator per
key: a stream name and its inputs (and, if the caller wants, a control or an attempt
number). The same key gives the same draws whatever ran before, and different keys give
independent streams (``numpy.random.SeedSequence`` with the key's digest as entropy words).
Keys are digested from their values, not from ``hash()``, which Python salts per process for
strings; values without a stable representation (``repr`` showing an address) are refused,
since they would silently make the draws differ between runs.

Written here rather than taken from a library: ``SeedSequence.spawn`` gives independent
children but keyed by spawn order, which is the dependence this module removes.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

_ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+")


def _canonical(value: Any) -> str:
    """A text that depends only on ``value``'s contents (floats by their exact ``repr``)."""
    if value is None or isinstance(value, bool | int | str):
        return repr(value)
    if isinstance(value, float | np.floating):
        number = float(value)
        return "nan" if math.isnan(number) else repr(number + 0.0)  # -0.0 and 0.0 alike
    if isinstance(value, np.integer):
        return repr(int(value))
    if isinstance(value, np.ndarray):
        return "a(" + ",".join(_canonical(v) for v in value.reshape(-1).tolist()) + ")"
    if isinstance(value, tuple | list):
        return "(" + ",".join(_canonical(v) for v in value) + ")"
    if isinstance(value, Mapping):
        items = sorted((_canonical(k), _canonical(v)) for k, v in value.items())
        return "{" + ",".join(f"{k}:{v}" for k, v in items) + "}"
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = ",".join(_canonical(getattr(value, f.name))
                          for f in dataclasses.fields(value))
        return f"{type(value).__qualname__}({fields})"
    text = repr(value)
    if _ADDRESS.search(text):
        raise TypeError(f"KeyedRandom: {type(value).__qualname__} has no stable "
                        "representation to key random draws by (its repr shows an address); "
                        "key by its contents instead")
    return text


def key_digest(*key: Any) -> int:
    """A 64-bit digest of ``key``'s values, the same in every process and on every machine."""
    text = _canonical(key).encode()
    return int.from_bytes(hashlib.blake2b(text, digest_size=8).digest(), "little")


class KeyedRandom:
    """Independent random generators per key, all fixed by one draw of ``rng``.

    ``keyed("sample-pose", block, region)`` returns a new generator each call; calls with
    equal keys return generators that make the same draws. Keep the generator for as long as
    the draws must differ (e.g. one per stream instance, for all its outputs).
    """

    def __init__(self, rng: np.random.Generator) -> None:
        self._root = int(rng.integers(0, 2**63))

    def __call__(self, *key: Any) -> np.random.Generator:
        digest = key_digest(*key)
        words = [self._root & 0xFFFFFFFF, self._root >> 32,
                 digest & 0xFFFFFFFF, digest >> 32]
        return np.random.default_rng(np.random.SeedSequence(words))

    def seed(self, *key: Any) -> int:
        """A non-negative 31-bit integer seed for ``key`` (for code that takes a seed)."""
        return int(self(*key).integers(0, 2**31 - 1))


__all__ = ["KeyedRandom", "key_digest"]
