"""Stream effort: how likely a stream call is to succeed and what it costs, and the order in
which a stream plan's instances are called.

The estimate blends three sources, as PDDLStream's learned effort does: the prior of the
binding (``StreamInfo.p_success`` and ``overhead``), the statistics persisted by earlier runs
of the same domain (:mod:`ltamp_cli.planner.statistics`) and the calls of the current run.
A stream plan is a conjunction: it is useful only if every call succeeds. Among instances
whose dependencies are already placed, the one with the smallest ``overhead / (1 − p)`` goes
first (Simon & Kadane's optimal order for independent conjunctive tests), so cheap calls that
are likely to fail are made before expensive ones whose result would be thrown away.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ltamp_cli.planner.streams import StreamInfo, StreamStats

# How many calls the prior counts for: history and the current run outweigh it quickly.
PRIOR_CALLS = 2.0
# Streams that never fail still need a finite key; their relative order stays by overhead.
MIN_FAILURE_PROBABILITY = 1e-3

# With ``PlannerConfig.eager_cheap_streams``, a stream observed this often to cost at most
# this much per call is evaluated eagerly, as if declared ``eager``: calling it on every real
# input is cheaper than the searches and failed stream plans its optimistic placeholders
# would cause. The threshold is far above the cost of closed-form Python samplers
# (~10-50 us) and below GP predictions and simulations, so measured time noise does not
# flip the decision in practice; with the current run's calls timed in CPU seconds, one
# call is enough to decide (three made cold kitchen_symbolic runs search 5-6 times, not 4).
AUTO_EAGER_MIN_CALLS = 1
AUTO_EAGER_MAX_OVERHEAD_S = 2.5e-4

InstanceKey = tuple[str, tuple[str, ...]]


@dataclass(frozen=True)
class Effort:
    """``p_success`` in [0, 1]; ``overhead_s``: expected seconds per call."""

    p_success: float
    overhead_s: float

    @property
    def order_key(self) -> float:
        """Expected cost per unit of failure probability (smaller is called first)."""
        return self.overhead_s / max(1.0 - self.p_success, MIN_FAILURE_PROBABILITY)


def estimate_effort(prior: StreamInfo, history: Mapping[str, float] | None,
                    run: StreamStats | None) -> Effort:
    """Blend a stream's prior with its persisted ``history`` (keys ``calls``, ``successes``,
    ``time_s``) and the current ``run``'s statistics (each may be missing).

    The current run's calls and successes count, but not its measured seconds: the order of
    stream plans must not depend on timing noise, or a run would not be deterministic for a
    given seed (two streams with equal counts were ordered by microseconds of noise). Its
    calls are costed at the prior-and-history mean overhead instead.
    """
    calls = PRIOR_CALLS
    successes = PRIOR_CALLS * prior.p_success
    seconds = PRIOR_CALLS * prior.overhead
    for source in (history or {},):
        calls += float(source.get("calls", 0.0))
        successes += float(source.get("successes", 0.0))
        seconds += float(source.get("time_s", 0.0))
    overhead = seconds / calls
    if run is not None:
        calls += run.calls
        successes += run.successes
    return Effort(min(1.0, successes / calls), overhead)


def observed_cheap(history: Mapping[str, float] | None, run: StreamStats | None) -> bool:
    """Whether the observed calls (persisted ``history`` plus this ``run``) show a stream to
    be cheap enough for eager evaluation; the prior does not count."""
    calls, seconds = 0.0, 0.0
    # Calls count with their CPU time: wall time depends on the machine's load, and one
    # preempted call of a 20 us sampler measures milliseconds. Histories from before CPU time
    # was persisted only have wall time.
    current = {"calls": run.calls, "cpu_s": run.cpu_s} if run is not None else {}
    for source in (history or {}, current):
        calls += float(source.get("calls", 0.0))
        seconds += float(source.get("cpu_s", source.get("time_s", 0.0)))
    return calls >= AUTO_EAGER_MIN_CALLS and seconds / calls <= AUTO_EAGER_MAX_OVERHEAD_S


def _as_totals(run: StreamStats | None) -> dict[str, float]:
    if run is None:
        return {}
    return {"calls": run.calls, "successes": run.successes, "time_s": run.time_s}


def order_by_effort(instances: Sequence[InstanceKey],
                    dependencies: Mapping[InstanceKey, set[InstanceKey]],
                    effort: Mapping[str, Effort]) -> list[InstanceKey]:
    """A topological order of ``instances`` (``dependencies[k]``: instances that must come
    before ``k``) that greedily calls the ready instance with the smallest effort key; ties
    keep the given order, so the result is deterministic."""
    position = {key: i for i, key in enumerate(instances)}
    remaining = list(instances)
    placed: set[InstanceKey] = set()
    ordered: list[InstanceKey] = []
    while remaining:
        ready = [k for k in remaining if dependencies.get(k, set()) <= placed]
        if not ready:  # a cycle cannot come from a stream plan; keep the given order
            ready = remaining[:1]
        best = min(ready, key=lambda k: (effort[k[0]].order_key, position[k]))
        remaining.remove(best)
        placed.add(best)
        ordered.append(best)
    return ordered
