"""Free a finished solve's memory in the background, piece by piece, after its result is out.

Freeing a large planner structure (a grounded task, an optimistic evaluation's fact index,
10^5-10^6 objects) is one C-level deallocation cascade: it holds the GIL for its whole
length, no deadline check can run inside it, and under load it took 0.75-1.3 s of wall
time past a solve's deadline (issue #19; ``docs/results/planner/issue19.md``). It happened
when the algorithm's function returned (its locals freed) and when the solve's state was
dropped, i.e. between the deadline and the caller getting its result.

So the watchdog captures the worker's call stack 1 s before the deadline and every 20 ms
from the deadline on (:func:`capture_stack`, :func:`.watchdog.run_until`): a frame object
that outlives its function keeps the function's locals alive (as a traceback does), so the
functions then return at once and the result reaches the caller; a :class:`Reclaimer`
thread then takes the captured locals (and the solve's state) apart in slices of a few
thousand items, and the interpreter lets other threads run between slices. Its CPU time
is within 5 % of a plain ``del`` (``bench/reclaim.py``).

Only what nobody else can reach is taken apart: a container or object whose only
references are the reclaimer's own (reference count), with no weak references and no
finalizer, so neither the caller, the result nor a still running worker can observe it.
Anything else is just dropped, and freed by its last owner as usual. Generator frames are
never touched (a suspended generator may still be resumed by its owner).

Interpreters. Written for CPython 3.11 (the project's) and read against 3.12/3.13: their
``frame.clear()`` refuses an executing or suspended frame with ``RuntimeError`` (skipped
here), 3.13's ``frame.f_locals`` is a write-through proxy (only its values are read), and
immortal objects report huge reference counts (never "exclusive"). Where the interpreter
does not match the reference-count reading that safety rests on, nothing is taken apart
and everything is only dropped (:func:`refcounts_exact`, checked on each
:func:`take_apart`): a build without the GIL (3.13t; no GIL to hand over between slices,
and counts of shared objects are not exact), one without ``sys.getrefcount``, or one whose
counts omit the references a caller holds on its stack (3.14 loads some locals as borrowed
references: a container the caller still held could then read as exclusive and be
emptied). Without ``sys._current_frames`` no stack is captured: the worker's functions free
their locals themselves when they return, as before the reclaimer.
"""

from __future__ import annotations

import inspect
import sys
import threading
import weakref
from collections import defaultdict
from collections.abc import Callable, Iterable
from itertools import repeat
from operator import itemgetter
from types import CodeType, FrameType

# Containers emptied item by item (exactly these types: a subclass may have a finalizer or
# custom removal). Tuples and frozensets cannot be emptied and are freed whole.
_MUTABLE_CONTAINERS = (dict, defaultdict, list, set)
_CONTAINER_TYPES = frozenset(_MUTABLE_CONTAINERS)
# A container found inside another is taken apart only above this size; smaller ones
# are freed whole (a cascade of at most a few hundred objects each).
SMALL_CONTAINER = 256
# Items removed from a container and freed at once: ~1 ms of CPU for small tuples.
ITEMS_PER_SLICE = 2048
_GENERATOR_FLAGS = (inspect.CO_GENERATOR | inspect.CO_COROUTINE
                    | inspect.CO_ASYNC_GENERATOR | inspect.CO_ITERABLE_COROUTINE)


def capture_stack(thread_id: int | None, stop_code: CodeType) -> list[FrameType]:
    """The frames running in thread ``thread_id`` above the one executing ``stop_code``
    (innermost first; that frame and its callers are excluded), or ``[]`` when the thread
    is not running. While a reference is held, each frame keeps its function's locals
    alive after the function returns."""
    current_frames = getattr(sys, "_current_frames", None)
    if thread_id is None or current_frames is None:
        return []
    frame = current_frames().get(thread_id)
    frames: list[FrameType] = []
    while frame is not None and frame.f_code is not stop_code:
        frames.append(frame)
        frame = frame.f_back
    if frame is None:  # the thread is no longer inside ``stop_code``: nothing of ours
        return []
    return frames


def refcounts_exact() -> bool:
    """Whether :func:`_exclusive` and :func:`take_apart` read reference counts right on
    this interpreter: a list held only by a local reads as exclusive and stops reading so
    once another list holds it, and an instance's attribute dict is held by the instance
    and one local only (see the module doc); with the GIL (no free-threaded build)."""
    if not hasattr(sys, "getrefcount") or getattr(sys, "_is_gil_enabled", _true)() is False:
        return False
    stack: list[object] = [[]]
    value = stack.pop()
    alone = _exclusive(value, 1)
    other = [value]
    shared = _exclusive(value, 1)
    del other
    probe = _Probe()
    attributes = vars(probe)
    own_dict = sys.getrefcount(attributes) == 3
    return alone and not shared and own_dict


def _true() -> bool:
    return True


class _Probe:
    """An instance with an attribute dict (:func:`refcounts_exact`)."""

    def __init__(self) -> None:
        self.attribute = None


def _exclusive(value: object, held: int) -> bool:
    """Whether ``value``'s only strong references are the ``held`` ones of the caller, with
    nothing that could observe its contents change: no weak reference and no finalizer.
    (``sys.getrefcount`` also counts this function's parameter and its own argument.)"""
    return (sys.getrefcount(value) == held + 2
            and (not type(value).__weakrefoffset__ or weakref.getweakrefcount(value) == 0)
            and getattr(type(value), "__del__", None) is None)


class Reclaimer:
    """Frees what it is given in a daemon thread, in bounded pieces (see the module doc).

    Thread-safe: :meth:`give` and :meth:`give_frames` may be called from any thread,
    before or after :meth:`start`; a gift after the thread has ended starts a new one.
    """

    def __init__(self, name: str = "ltamp-reclaim") -> None:
        self._name = name
        self._when_done: Callable[[], None] | None = None
        self._lock = threading.Lock()
        self._pending: list[object] = []
        self._frames: list[FrameType] = []
        self._thread: threading.Thread | None = None
        self._started = False
        self._frames_given = 0

    @property
    def has_frames(self) -> bool:
        """Whether any frame was given (:meth:`give_frames`)."""
        return self._frames_given > 0

    def give(self, values: Iterable[object]) -> None:
        """Hand over references to ``values`` (the caller should then drop its own)."""
        with self._lock:
            self._pending.extend(values)
            self._wake()

    def give_frames(self, frames: Iterable[FrameType]) -> None:
        """Hand over frames whose functions have returned (or will, in another thread):
        a returned function's locals are taken apart, a running one's are left alone."""
        frames = list(frames)
        with self._lock:
            self._frames.extend(frames)
            self._frames_given += len(frames)
            self._wake()

    def start(self, when_done: Callable[[], None] | None = None) -> None:
        """Begin freeing (in the background) what was and will be given; ``when_done`` is
        called (in the background thread) once all of it was freed."""
        with self._lock:
            self._started = True
            self._when_done = when_done
            self._wake()

    def join(self, timeout: float | None = None) -> bool:
        """Wait for the background thread (tests, benchmarks); ``True`` when it is done."""
        with self._lock:
            thread = self._thread
        if thread is not None:
            thread.join(timeout)
            return not thread.is_alive()
        return True

    def _wake(self) -> None:
        """Start the thread if there is work and none runs (call with the lock held)."""
        if not self._started or not (self._pending or self._frames):
            return
        if self._thread is None or not self._thread.is_alive():
            self._thread = threading.Thread(target=self._run, name=self._name, daemon=True)
            self._thread.start()

    def _take(self) -> tuple[list[object], list[FrameType]]:
        with self._lock:
            pending, self._pending = self._pending, []
            frames, self._frames = self._frames, []
            if not pending and not frames:
                self._thread = None  # a later gift starts a new thread
            return pending, frames

    def _run(self) -> None:
        try:
            while True:
                pending, frames = self._take()
                if not pending and not frames:
                    return
                pending.extend(_locals_of(frames))
                del frames
                take_apart(pending)
        finally:  # also if taking apart failed: ``when_done`` may release a global hold
            with self._lock:
                when_done, self._when_done = self._when_done, None
            if when_done is not None:
                when_done()


def _running_frames() -> set[int]:
    """Ids of the frames on some thread's stack now."""
    running: set[int] = set()
    for frame in sys._current_frames().values():
        walk: FrameType | None = frame
        while walk is not None:
            running.add(id(walk))
            walk = walk.f_back
    return running


def _locals_of(frames: list[FrameType]) -> list[object]:
    """The locals of the returned, non-generator frames among ``frames`` (which is
    emptied: the frames are dropped). A frame still running (an abandoned worker's) keeps
    its locals: dropping the reference to it frees nothing."""
    values: list[object] = []
    if not hasattr(sys, "_current_frames"):
        frames.clear()
        return values
    running = _running_frames()
    seen: set[int] = set()
    while frames:
        frame = frames.pop()
        if (id(frame) in seen or id(frame) in running
                or frame.f_code.co_flags & _GENERATOR_FLAGS):
            continue
        seen.add(id(frame))
        local_values = list(frame.f_locals.values())
        try:
            frame.clear()  # the locals are now held by ``local_values`` only
        except RuntimeError:  # running after all (it was not when ``running`` was taken)
            continue
        values.extend(local_values)
    return values


def take_apart(values: list[object]) -> None:
    """Drop ``values`` (a list the caller gives up: it is emptied), taking apart in small
    pieces every container and object in it that is referenced from here only, so that no
    single deallocation frees more than a few thousand objects at once."""
    if not refcounts_exact():
        values.clear()  # dropped: each freed by its last owner, as without a reclaimer
        return
    stack = values
    while stack:
        value = stack.pop()
        # References: ``value`` (this frame) only.
        if not _exclusive(value, 1):
            continue
        kind = type(value)
        if kind in _CONTAINER_TYPES:
            _empty_into(value, stack)  # type: ignore[arg-type]
        elif _plain_instance(value):
            attributes = vars(value)
            # The attribute dict's references: the instance and ``attributes``.
            if type(attributes) is dict and sys.getrefcount(attributes) == 3:
                stack.extend(attributes.values())
                attributes.clear()
        del value


def _plain_instance(value: object) -> bool:
    """An instance of a class defined in Python code (not a class, module or function),
    with an attribute dict."""
    return (not isinstance(value, type) and type(value).__module__ != "builtins"
            and hasattr(value, "__dict__"))


def _empty_into(container: dict[object, object] | list[object] | set[object],
                stack: list[object]) -> None:
    """Empty ``container`` :data:`ITEMS_PER_SLICE` items at a time (removed in a C loop,
    freed by one ``del``), pushing its large containers onto ``stack`` (taken apart in
    turn). Between slices, the interpreter hands the GIL to a thread that waits for it
    (within its switch interval, 5 ms). Only lists and dict values are searched for
    containers: set members and dict keys are hashable, so never a dict, list or set."""
    if isinstance(container, set):
        pop = container.pop  # pop: iterating from the start would skip emptied slots
        while container:
            piece: list[object] = [pop() for _ in repeat(None, min(ITEMS_PER_SLICE,
                                                                    len(container)))]
            del piece
        return
    while container:
        if isinstance(container, dict):
            popitem = container.popitem
            pairs = [popitem() for _ in repeat(None, min(ITEMS_PER_SLICE, len(container)))]
            piece = list(map(itemgetter(1), pairs))
            del pairs  # the keys go; the values are held by ``piece``
        else:
            piece = container[-ITEMS_PER_SLICE:]
            del container[-ITEMS_PER_SLICE:]
        if not _CONTAINER_TYPES.isdisjoint(map(type, piece)):  # rare: look closer
            stack.extend([item for item in piece if type(item) in _CONTAINER_TYPES
                          and len(item) > SMALL_CONTAINER])  # type: ignore[arg-type]
        del piece  # frees the slice's other items
