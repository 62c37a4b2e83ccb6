"""Which unit of work of ``python -m bench.paper`` runs next on ``--jobs`` lanes.

A *unit* is a trial-pool collection (``pool:<backend>_<skill>``), a whole experiment
(``al2d``) or one independent part of a split experiment (``sampling:3D-pybullet-pour``).
Units run one per lane (a lane is one process, so ``--jobs 2`` keeps two processes busy
on two cores, pool collection included: it no longer runs as two extra worker processes
beside two experiments). A unit may wait for others (the pool experiments wait for their
pools).

Order: critical-path first. A unit's *rank* is its estimated CPU seconds plus the largest
rank among the units waiting for it; the free lane takes the ready unit with the highest
rank. Without dependencies that is longest-first, which makes the lanes end close together
(a long unit started last would run alone at the end). The estimates (CPU seconds measured
in earlier quick runs, see ``bench.paper.__main__``) only order the units: a wrong estimate
costs time, never results.
"""

from __future__ import annotations

import heapq
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Unit:
    """One schedulable piece of work.

    ``key``: unique name; ``experiment``: the experiment it produces (or ``None`` for a pool);
    ``part``: the part of a split experiment (``None``: the whole experiment or a pool);
    ``cost``: estimated CPU seconds (ordering only); ``after``: keys that must finish first.
    """

    key: str
    experiment: str | None
    part: str | None = None
    cost: float = 0.0
    after: tuple[str, ...] = field(default=())


def ranks(units: Sequence[Unit]) -> dict[str, float]:
    """Critical-path rank of every unit: its cost plus the largest rank of its dependents (s).

    Raises ``ValueError`` for an unknown dependency or a cycle.
    """
    by_key = {u.key: u for u in units}
    dependents: dict[str, list[str]] = {u.key: [] for u in units}
    for unit in units:
        for before in unit.after:
            if before not in by_key:
                raise ValueError(f"unit {unit.key!r} waits for unknown unit {before!r}")
            dependents[before].append(unit.key)
    rank: dict[str, float] = {}
    visiting: set[str] = set()

    def visit(key: str) -> float:
        if key in rank:
            return rank[key]
        if key in visiting:
            raise ValueError(f"dependency cycle through unit {key!r}")
        visiting.add(key)
        rank[key] = by_key[key].cost + max((visit(d) for d in dependents[key]), default=0.0)
        visiting.discard(key)
        return rank[key]

    for unit in units:
        visit(unit.key)
    return rank


def pick(ready: Sequence[Unit], rank: Mapping[str, float]) -> Unit:
    """The ready unit to start next: highest rank, then highest cost, then listing order."""
    order = {u.key: i for i, u in enumerate(ready)}
    return max(ready, key=lambda u: (rank[u.key], u.cost, -order[u.key]))


def ready_units(pending: Sequence[Unit], finished: set[str]) -> list[Unit]:
    """The pending units whose dependencies have all finished (listing order kept)."""
    return [u for u in pending if set(u.after) <= finished]


def simulate(units: Sequence[Unit], lanes: int) -> tuple[float, list[list[str]]]:
    """Makespan (s) and per-lane unit keys if every unit took exactly its ``cost`` on
    ``lanes`` dedicated cores, started in :func:`pick` order (the estimate the runner's
    summary prints, and what the tests check the order against)."""
    if lanes < 1:
        raise ValueError(f"lanes must be >= 1, got {lanes}")
    rank = ranks(units)
    pending = list(units)
    finished: set[str] = set()
    running: list[tuple[float, int, str]] = []  # (end time, lane, key) heap
    free = list(range(lanes))
    assignment: list[list[str]] = [[] for _ in range(lanes)]
    now = 0.0
    while pending or running:
        ready = ready_units(pending, finished)
        while ready and free:
            unit = pick(ready, rank)
            lane = free.pop(0)
            assignment[lane].append(unit.key)
            heapq.heappush(running, (now + unit.cost, lane, unit.key))
            pending.remove(unit)
            ready.remove(unit)
        if not running:
            raise ValueError("units wait for each other and none can start")
        now, lane, key = heapq.heappop(running)
        finished.add(key)
        free.append(lane)
        free.sort()
    return now, assignment
