"""The planner's deadline, checked inside grounding, axiom compilation and search."""

from __future__ import annotations

import time

NO_DEADLINE = float("inf")


class SearchTimeout(Exception):
    """The deadline passed during grounding, task construction or search."""


def check_deadline(deadline: float) -> None:
    """Raise :class:`SearchTimeout` once ``time.perf_counter()`` is past ``deadline``
    (about 50 ns a call: cheap enough for per-fact loops)."""
    if time.perf_counter() > deadline:
        raise SearchTimeout
