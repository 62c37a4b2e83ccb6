"""The cyclic garbage collector during a solve: run by the solve's waiting thread, at times
that keep every collection clear of the deadline.

A collection is one C call that holds the GIL: generation-1 and full collections of a
large solve took 0.24-0.54 s of wall time under load, one of them at 56 s of a 60 s solve,
and nothing (neither the planner's clock checks nor the watchdog) can run inside one
(issue #19). So while a solve runs, automatic collection is off (:class:`PausedCollection`)
and the thread that waits for the solve's worker collects instead
(:class:`CollectionPacer`): by CPython's own rule (generation thresholds, a full
collection once the heap grew by a quarter), but only when the collection's expected
length, measured on this solve's earlier collections, ends well before the deadline.
A collection that would not is skipped (a younger generation's is run instead, if it
fits). When the last solve ends, the objects in the young generations are moved to the
oldest one without a collection (``gc.freeze`` and ``gc.unfreeze``, two list splices),
so the caller's collector, back on, does not start with the skipped collections due: they
would run at its next allocation, before the solve has even returned (1.0-1.5 s of wall
time at load 9 for hidden robots2_4 and handoff_2 with ``max_time`` 15).
"""

from __future__ import annotations

import gc
import os
import sys
import threading
import time
import weakref
from collections.abc import Callable, Iterator
from contextlib import contextmanager

# Generation-0 threshold while a solve runs (CPython's default is 700). Search and grounding
# allocate many short-lived tuples, sets and dicts that reference counting frees anyway; at
# the default threshold the collector ran often enough to cost ~5-10 % of the CPU time of
# kitchen_symbolic and tamp2d_4blocks. Not disabled outright: a long solve with learned
# samplers could otherwise accumulate cyclic garbage without bound.
SOLVE_GC_THRESHOLD0 = 50_000
# Seconds between two looks at the collector's counts by the waiting thread.
PACE_S = 0.02
# A collection starts only if the deadline is further than this many times its expected
# wall time (estimates are from this solve's own earlier collections, at its load).
DEADLINE_SAFETY = 4.0
# Wall seconds per unit of size (:meth:`CollectionPacer.size`) assumed for a generation no
# collection of which was measured yet in this solve: 10-30 ns of CPU per object, times the
# wall/CPU ratio of a loaded machine. A full collection of hidden handoff_2 at load 12.8
# took 1.8 s, about 5e-7 s per allocated block, after one estimated from the young
# generations' rate (a different unit) had started 0.8 s before the deadline.
DEFAULT_WALL_PER_UNIT_S = 1e-6
# Estimates use the slowest of this many last measured rates of a generation.
RATES_KEPT = 3
# A full collection is due once the heap grew by this factor since the last one (CPython
# runs it once the objects awaiting one exceed a quarter of those that survived one).
FULL_GROWTH = 1.25


class PausedCollection:
    """Automatic garbage collection off while at least one solve runs.

    The collector's switch is process-wide, so it is turned off only while a solve is in
    progress and restored when the last concurrent one ends (also on exceptions): the lock
    and the depth count mirror that interpreter-wide state and hold no planner data, so
    planners in different threads still do not interfere. A caller that had switched the
    collector off keeps it off, and its solves collect nothing (:attr:`caller_enabled`).
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._depth = 0
        self._enabled = gc.isenabled()
        self._frozen_holds = 0  # background releases under way (see hold_frozen)
        if hasattr(os, "register_at_fork"):  # not on Windows (no fork there)
            method = weakref.WeakMethod(self._after_fork_in_child)
            os.register_at_fork(after_in_child=lambda: _call_if_alive(method))

    def _after_fork_in_child(self) -> None:
        """In a child process forked while solves ran in other threads, or while a
        reclaimer held memory frozen: those threads do not exist in the child, so nothing
        would ever end their pause or release their hold. Before, such a child (a
        ``multiprocessing`` pool forked while a solve runs in a thread) kept automatic
        collection off for good, and its own solves never turned it back on (the depth
        count never returned to 0). The child starts with no solve running: the caller's
        collector setting comes back, the hold's freeze is undone, and the lock, which
        another thread may have held at the fork, is new."""
        self._lock = threading.Lock()
        if self._frozen_holds:
            self._frozen_holds = 0
            gc.unfreeze()
        if self._depth:
            self._depth = 0
            if self._enabled:
                gc.enable()

    @property
    def caller_enabled(self) -> bool:
        """Whether the collector was on when the outermost running solve began."""
        return self._enabled

    @contextmanager
    def __call__(self) -> Iterator[None]:
        with self._lock:
            if self._depth == 0:
                self._enabled = gc.isenabled()
                gc.disable()
            self._depth += 1
        try:
            yield
        finally:
            with self._lock:
                self._depth -= 1
                if self._depth == 0 and self._enabled:
                    if self._frozen_holds:  # unfrozen with the rest when the holds end
                        gc.freeze()
                    else:
                        _age_young_objects()
                    gc.enable()

    def hold_frozen(self) -> Callable[[], None]:
        """Move every tracked object to the permanent generation (``gc.freeze``) until the
        returned function is called, for a solve's memory that a background thread frees
        after the solve returned (:mod:`.reclaim`): no collection examines it meanwhile,
        not even the one the interpreter runs when the process exits (measured, hidden
        handoff_2 freed in the background: 1.6 s from the return to the exit of the
        process at load ~11, 0.08 s frozen). Unfrozen when the last concurrent hold ends;
        nothing is done when the caller froze objects itself (``gc.unfreeze`` would
        unfreeze those too)."""
        with self._lock:
            if self._frozen_holds == 0 and gc.get_freeze_count():
                return _nothing
            gc.freeze()
            self._frozen_holds += 1
        return self._release_frozen

    def _release_frozen(self) -> None:
        with self._lock:
            self._frozen_holds -= 1
            if self._frozen_holds == 0:
                gc.unfreeze()


def _call_if_alive(method: weakref.WeakMethod[Callable[[], None]]) -> None:
    """Call a weakly referenced method, unless its object was freed."""
    function = method()
    if function is not None:
        function()


def _nothing() -> None:
    """A release that has nothing to release."""


def _age_young_objects() -> None:
    """Move every object of the young generations to the oldest one, without examining
    any (see the module doc). Not done when the caller froze objects itself:
    ``gc.unfreeze`` would unfreeze those too."""
    if gc.get_freeze_count() == 0:
        gc.freeze()
        gc.unfreeze()


class CollectionPacer:
    """Collects garbage for one solve from the thread waiting for it (see the module doc).

    ``deadline``: ``time.perf_counter`` seconds (``inf``: no limit); ``enabled``: whether
    the caller's collector was on (off: never collect).

    A collection's length is predicted from a size measure per generation that is safe to
    read while the worker runs (:meth:`size`) times the wall seconds per unit of it that
    this solve's recent collections of that generation took (the slowest of the last
    :data:`RATES_KEPT`: the machine's load varies). ``gc.get_objects`` would count exactly,
    but it hands out objects the worker is still constructing (a tuple being built saw its
    reference count change and raised ``SystemError``).
    """

    def __init__(self, deadline: float, enabled: bool) -> None:
        self.deadline = deadline
        self.enabled = enabled
        _, threshold1, threshold2 = gc.get_threshold()
        self.thresholds = (SOLVE_GC_THRESHOLD0, threshold1, threshold2)
        # Wall seconds per unit of :meth:`size`, last collections, per generation.
        self.rates: tuple[list[float], ...] = ([], [], [])
        self.blocks_after_full = sys.getallocatedblocks()
        self.collections = [0, 0, 0]  # run, per generation
        self.skipped = [0, 0, 0]  # due but too near the deadline, per generation

    def due(self) -> int | None:
        """The generation CPython would collect now (``None``: none)."""
        count = gc.get_count()
        threshold0, threshold1, threshold2 = self.thresholds
        if count[0] <= threshold0:
            return None
        if (count[2] > threshold2
                and sys.getallocatedblocks() > FULL_GROWTH * self.blocks_after_full):
            return 2
        return 1 if count[1] > threshold1 else 0

    def size(self, generation: int) -> int:
        """A measure of what a collection of ``generation`` examines: the objects allocated
        since the last collection (young), plus one generation-0 threshold per collection
        since the last generation-1 one (a bound on their survivors), or the interpreter's
        allocated memory blocks (full: all objects, and some the collector does not follow)."""
        count = gc.get_count()
        if generation == 0:
            return count[0]
        if generation == 1:
            return count[0] + count[1] * self.thresholds[0]
        return sys.getallocatedblocks()

    def wall_per_unit(self, generation: int) -> float:
        """Expected wall seconds per unit of :meth:`size` for ``generation`` (generation
        1: generation 0's rate until one of its own was measured; the size of generation 1
        bounds the objects of generation 0 from above, so that errs long)."""
        rates = self.rates[generation] or (self.rates[0] if generation == 1 else [])
        return max(rates[-RATES_KEPT:], default=DEFAULT_WALL_PER_UNIT_S)

    def expected_s(self, generation: int) -> float:
        """Expected wall seconds of a collection of ``generation`` now."""
        return self.size(generation) * self.wall_per_unit(generation)

    def tick(self) -> None:
        """Collect what is due, unless it could still run at the deadline: then the
        youngest generations' collection that fits, if any."""
        if not self.enabled:
            return
        due = self.due()
        if due is None:
            return
        now = time.perf_counter()
        for generation in range(due, -1, -1):
            if now + DEADLINE_SAFETY * self.expected_s(generation) <= self.deadline:
                break
            self.skipped[generation] += 1
        else:
            return
        size = self.size(generation)
        gc.collect(generation)
        wall = time.perf_counter() - now
        self.collections[generation] += 1
        rates = self.rates[generation]
        rates.append(wall / max(size, 1))
        del rates[:-RATES_KEPT]
        if generation == 2:
            self.blocks_after_full = sys.getallocatedblocks()
