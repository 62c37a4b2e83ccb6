"""Trial collection on a Ray cluster (``ltamp collect --ray ADDRESS``; extra ``ltamp[ray]``).

Each Ray actor holds one :class:`~ltamp_cli.trials.collect.TrialRunner` (so a backend's world
is built once per actor and reused across its trials) and returns each finished trial as a
JSON line tagged with its index. Only the driver writes the output file, in the order trials
finish, which keeps the same append-only, resumable file as local collection: what was
appended survives a kill, and a rerun skips those indices.

Ray is imported only here and only when ``--ray`` is used. ``"local"`` starts a private local
cluster with ``num_cpus=workers`` (shut down at the end); any other address is handed to
``ray.init(address=...)``, whose nodes must have ``ltamp`` installed. If Ray is already
initialised in this process (library use), that session is used and left running.
"""

from __future__ import annotations

import json
import logging
import os
import re
import socket
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import ModuleType
from typing import Any

from ltamp_cli.errors import InputError
from ltamp_cli.trials.collect import CollectJob, TrialRunner
from ltamp_cli.trials.record import TrialRecord

# The plasma store is sized for trial records (a few kB each), not for Ray's default share
# of RAM, so a local cluster also starts on small or busy machines.
LOCAL_OBJECT_STORE_BYTES = 100 * 1024 * 1024
# How long to wait for a cluster address to accept a TCP connection before giving up.
PROBE_TIMEOUT_S = 10.0


def import_ray() -> ModuleType:
    """The ``ray`` module, or a one-line :class:`InputError` saying how to install it."""
    try:
        import ray
    except ImportError:
        raise InputError(
            "--ray needs Ray, which is not installed; install the extra: pip install 'ltamp[ray]'"
        ) from None
    return ray


class RayTrialActor:
    """The body of a Ray actor: runs trials of one job, returning JSON records."""

    def __init__(self, job: CollectJob) -> None:
        self.runner = TrialRunner(job)

    def run(self, index: int) -> str:
        return self.runner.run(index).to_json()


def _probe(address: str) -> None:
    """Fail fast on an unreachable ``[ray://]host:port`` (Ray itself retries for minutes)."""
    match = re.fullmatch(r"(?:ray://)?\[?([^\[\]]+?)\]?:(\d+)", address.strip())
    if match is None:  # e.g. "auto": let Ray resolve it
        return
    host, port = match.group(1), int(match.group(2))
    try:
        with socket.create_connection((host, port), timeout=PROBE_TIMEOUT_S):
            pass
    except OSError as error:
        reason = error.strerror or type(error).__name__
        raise InputError(f"--ray: cannot reach a Ray cluster at {address!r} ({reason})") from None


@contextmanager
def ray_session(address: str, workers: int | None) -> Iterator[ModuleType]:
    """Ray initialised for ``address`` (``"local"``: a new local cluster of ``workers`` CPUs),
    shut down on exit if this call started or joined it. Errors are one-line InputErrors."""
    ray = import_ray()
    if ray.is_initialized():
        yield ray
        return
    options: dict[str, Any] = {
        "include_dashboard": False,
        "log_to_driver": False,
        "logging_level": logging.ERROR,
    }
    try:
        if address == "local":
            ray.init(
                num_cpus=workers or os.cpu_count() or 1,
                object_store_memory=LOCAL_OBJECT_STORE_BYTES,
                **options,
            )
        else:
            _probe(address)
            ray.init(address=address, **options)
    except InputError:
        raise
    except Exception as error:  # bad address or cluster: one line, exit 2
        message = " ".join(str(error).split())[:300]
        raise InputError(f"--ray: cannot start or join Ray at {address!r}: {message}") from None
    try:
        yield ray
    finally:
        ray.shutdown()


def ray_stream(
    ray: ModuleType, job: CollectJob, indices: list[int], workers: int | None
) -> Iterator[TrialRecord]:
    """Run trials ``indices`` of ``job`` on actors of the initialised ``ray`` (see
    :func:`ray_session`); yields records as they finish.

    ``workers`` actors (``None``: one per CPU of the cluster), never more than the cluster's
    CPUs (an actor that cannot be placed would hold its trials forever) nor than trials.
    """
    if not indices:
        return
    from ray.util import ActorPool

    cpus = max(1, int(ray.cluster_resources().get("CPU", 1)))
    count = max(1, min(workers or cpus, cpus, len(indices)))
    actor_class = ray.remote(num_cpus=1)(RayTrialActor)
    actors = [actor_class.remote(job) for _ in range(count)]
    submit: Callable[[Any, int], Any] = lambda actor, index: actor.run.remote(index)  # noqa: E731
    try:
        for payload in ActorPool(actors).map_unordered(submit, indices):
            yield TrialRecord.from_dict(json.loads(payload))
    finally:
        for actor in actors:
            ray.kill(actor)
