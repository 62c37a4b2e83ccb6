"""The hard time limit of a solve: the planner runs in a worker thread that the caller waits
for, at most until the deadline plus a grace period.

The planner checks its clock itself (in grounding, axiom compilation, search and stream-plan
evaluation) and normally stops on time. What it cannot interrupt is a stream binding: a
generator that sleeps, blocks on I/O or never yields keeps the call from returning. The
caller's thread therefore waits on the worker with a timeout and, when that runs out,
*abandons* the worker:

* the worker is told it was cancelled, so as soon as the binding returns (if it ever does)
  the planner times out at its next clock check, calls no further stream and writes no
  statistics; its results are discarded;
* a binding that never returns keeps its (daemon) thread, and whatever CPU it burns, until
  the process exits — Python cannot kill a thread. Its generator is never resumed again;
* the caller gets a ``timeout`` result naming the stream call that was running
  (:class:`CallTracker`) and the statistics gathered so far;
* when the interpreter exits, it first waits (at most :data:`EXIT_WAIT_S` in all) for the
  abandoned workers still alive (:class:`AbandonedWorkers`): a daemon thread still inside
  native code while Python finalises can abort the process ("Fatal Python error:
  PyGILState_Release ... finalizing", seen after timed-out PyBullet solves in plain
  scripts); a cancelled worker normally ends as soon as its stream call returns.

One worker thread per solve (tens of microseconds) rather than one per stream call: cheap
streams are called thousands of times per solve.
"""

from __future__ import annotations

import atexit
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from types import CodeType, FrameType
from typing import Generic, TypeVar

from ltamp_cli.planner.gc_pacing import PACE_S
from ltamp_cli.planner.reclaim import Reclaimer, capture_stack

T = TypeVar("T")

# Seconds the caller waits beyond the deadline before abandoning the worker: the planner's
# own clock checks normally end it well within this; the rest of the 1 s bound is left for
# building the result.
ABANDON_GRACE_S = 0.5
# Seconds before the deadline at which the worker's stack is first captured (see
# :func:`run_until`): a solve that ends within this of its deadline frees its locals in the
# background, one that ends earlier frees them before returning (with time to spare).
CAPTURE_LEAD_S = 1.0
# Seconds the interpreter's exit waits, in all, for abandoned workers to end (their stream
# call to return: a motion planner's query is capped at a few seconds). Past it the process
# exits as before (a binding that never returns cannot be waited for).
EXIT_WAIT_S = 10.0


@dataclass(frozen=True)
class RunningCall:
    """A stream call in progress: the stream's name, its input objects and when it started
    (``time.perf_counter`` seconds)."""

    stream: str
    inputs: tuple[str, ...]
    started: float

    def describe(self, now: float) -> str:
        return (f"stream {self.stream!r} (inputs {', '.join(self.inputs) or 'none'}) "
                f"running for {now - self.started:.2f} s")


class CallTracker:
    """Which stream call the worker is in (written by the worker, read by the caller), and
    whether the caller has abandoned the worker."""

    def __init__(self) -> None:
        self.running: RunningCall | None = None
        self._cancelled = threading.Event()

    def cancel(self) -> None:
        self._cancelled.set()

    @property
    def cancelled(self) -> bool:
        return self._cancelled.is_set()


class AbandonedWorkers:
    """The abandoned solve workers of the process, waited for when the interpreter exits
    (an :mod:`atexit` hook registered at the first abandonment: nothing at import)."""

    def __init__(self, wait_s: float = EXIT_WAIT_S) -> None:
        self.wait_s = wait_s
        self._lock = threading.Lock()
        self._threads: list[threading.Thread] = []
        self._registered = False

    def add(self, thread: threading.Thread) -> None:
        with self._lock:
            self._threads = [t for t in self._threads if t.is_alive()]
            self._threads.append(thread)
            if not self._registered:
                self._registered = True
                atexit.register(self.wait)

    def wait(self) -> None:
        """Join the abandoned workers still alive, for at most ``wait_s`` seconds in all."""
        with self._lock:
            threads, self._threads = self._threads, []
        end = time.monotonic() + self.wait_s
        for thread in threads:
            thread.join(max(0.0, end - time.monotonic()))


_abandoned_workers = AbandonedWorkers()


@dataclass
class _Outcome(Generic[T]):
    value: T | None = None
    error: BaseException | None = None
    done: bool = False


def run_until(work: Callable[[], T], deadline: float, tracker: CallTracker,
              name: str = "ltamp-solve", *, reclaimer: Reclaimer | None = None,
              tick: Callable[[], None] | None = None) -> tuple[bool, T | None]:
    """Run ``work()`` in a daemon thread and wait for it until ``deadline`` (a
    ``time.perf_counter`` value, ``inf`` for no limit) plus :data:`ABANDON_GRACE_S`.

    Returns ``(True, value)`` when it finished (its exception, if any, is re-raised here) or
    ``(False, None)`` when it was abandoned (``tracker`` is then cancelled).

    While waiting, calls ``tick()`` every :data:`~.gc_pacing.PACE_S` seconds until the
    deadline (the solve's garbage collection). With a ``reclaimer``, the worker's stack is
    captured :data:`CAPTURE_LEAD_S` before the deadline and every ``PACE_S`` from the
    deadline on (:func:`.reclaim.capture_stack`), so that the functions running then do not
    free their locals when they return (one uninterruptible deallocation each, up to
    seconds under load): the reclaimer gets them, to free in the background once the caller
    has the result.
    """
    outcome: _Outcome[T] = _Outcome()
    finished = threading.Event()

    def target() -> None:
        try:
            outcome.value = work()
        except BaseException as error:  # handed to the caller's thread
            outcome.error = error
        finally:
            outcome.done = True
            finished.set()

    worker = threading.Thread(target=target, name=name, daemon=True)
    worker.start()
    captured: dict[int, FrameType] = {}  # by id (each frame is kept alive here)
    try:
        _wait(worker, finished, deadline, reclaimer, tick, captured, target.__code__)
    except BaseException:
        # KeyboardInterrupt (or an error in ``tick``) in the waiting thread: the caller gets
        # it, and the worker, which nobody waits for any more, is told to stop at its next
        # clock check or stream call, as an abandoned one (before, an interrupted API solve
        # went on calling the user's streams until its max_time, inf by default).
        tracker.cancel()
        if not outcome.done:
            _abandoned_workers.add(worker)
        raise
    if reclaimer is not None:
        reclaimer.give_frames(captured.values())
        captured.clear()
    if not outcome.done:
        tracker.cancel()
        _abandoned_workers.add(worker)
        return False, None
    if outcome.error is not None:
        raise outcome.error
    return True, outcome.value


def _wait(worker: threading.Thread, finished: threading.Event, deadline: float,
          reclaimer: Reclaimer | None, tick: Callable[[], None] | None,
          captured: dict[int, FrameType], stop_code: CodeType) -> None:
    """The waiting loop of :func:`run_until`: until ``finished`` is set or the deadline
    plus the grace period, capturing the worker's stack into ``captured`` (with a
    ``reclaimer``) and calling ``tick``."""
    next_capture = deadline - CAPTURE_LEAD_S if reclaimer is not None else math.inf
    abandon_at = deadline + ABANDON_GRACE_S
    while True:
        now = time.perf_counter()
        if now >= next_capture:
            for frame in capture_stack(worker.ident, stop_code):
                captured.setdefault(id(frame), frame)
            # Past the deadline, the frames the worker enters while it stops are taken too.
            next_capture = max(deadline, now + PACE_S)
        if now >= abandon_at:
            break
        wake = min(abandon_at, next_capture)
        if tick is not None:
            wake = min(wake, now + PACE_S)
        # A limit beyond what a lock wait takes (max_time=1e308) is no limit: wait() would
        # raise OverflowError ("timestamp out of range for platform time_t").
        timeout = wake - now
        if finished.wait(None if timeout >= threading.TIMEOUT_MAX else max(0.0, timeout)):
            break
        if tick is not None and time.perf_counter() < deadline:
            tick()
