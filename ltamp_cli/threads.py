"""Thread limits for numerics: the GPs and samplers of ltamp are small.

Small GP fits and predictions run several times slower on two threads than on one (OpenMP
and OpenBLAS oversubscription, see the field facts). Every ``ltamp`` command therefore limits
the thread pools to one thread with :func:`use_one_thread`, and the Python API's entry points
(:func:`ltamp_cli.planner.api.solve`, :func:`ltamp_cli.learning.active.learn_online` and
``learn_from_pool``, see :func:`limits_threads`) run inside :func:`limited_threads` with the
``threads`` of their config (default 1; ``None`` leaves the pools alone), so the API behaves
like the command line.

Only pools already loaded are limited (numpy's and scipy's OpenBLAS, torch's OpenMP via
threadpoolctl, and torch's own intra-op pool): call these after the imports that matter.
"""

from __future__ import annotations

import functools
import inspect
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, ParamSpec, TypeVar

if TYPE_CHECKING:
    from threadpoolctl import ThreadpoolController

P = ParamSpec("P")
R = TypeVar("R")


def use_one_thread() -> None:
    """Limit every loaded thread pool to one thread for the rest of the process (the CLI)."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(1)


@contextmanager
def limited_threads(limit: int | None = 1) -> Iterator[None]:
    """Within the block, every loaded thread pool uses at most ``limit`` threads; the previous
    limits are restored after it. ``None``: no change."""
    if limit is None:
        yield
        return
    if limit < 1:
        raise ValueError(f"threads: expected a number >= 1 or None, got {limit}")
    torch = sys.modules.get("torch")
    torch_threads = torch.get_num_threads() if torch is not None else None
    loaded = frozenset(name for name in _POOL_OWNERS if name in sys.modules)
    with _controller(loaded).limit(limits=limit):
        if torch is not None:
            torch.set_num_threads(limit)
        try:
            yield
        finally:
            if torch is not None and torch_threads is not None:
                torch.set_num_threads(torch_threads)


#: Packages whose import loads a thread pool (OpenBLAS, OpenMP).
_POOL_OWNERS = ("numpy", "scipy", "sklearn", "torch")


@functools.cache
def _controller(loaded: frozenset[str]) -> ThreadpoolController:
    """The thread pools loaded once the packages ``loaded`` were imported. Inspecting the
    loaded libraries costs ~3 ms and leaves reference cycles per ``threadpool_limits`` call,
    while a solve of a small problem takes ~20 ms; pools come with these packages' imports, so
    one inspection per set of imported packages suffices (at most 2**4, never evicted: an
    evicted controller would be cyclic garbage)."""
    del loaded  # the cache key
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def limits_threads(function: Callable[P, R]) -> Callable[P, R]:
    """Decorate an API entry point whose argument ``config`` has a ``threads`` field: the call
    runs inside :func:`limited_threads` of that field."""
    signature = inspect.signature(function)

    @functools.wraps(function)
    def limited(*args: P.args, **kwargs: P.kwargs) -> R:
        config = signature.bind(*args, **kwargs).arguments["config"]
        with limited_threads(getattr(config, "threads", 1)):
            return function(*args, **kwargs)

    return limited


__all__ = ["limited_threads", "limits_threads", "use_one_thread"]
