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

# With ``PlannerConfig.eager_cheap_streams``, a stream observed to be cheap is evaluated
# eagerly, as if declared ``eager``: calling it on every real input is cheaper than the
# searches and failed stream plans its optimistic placeholders would cause (test streams
# always; see ``PlannerState.eager``). The decision (:func:`observed_cheap`) is made once
# per stream and solve, from at least this many observed calls.
AUTO_EAGER_MIN_CALLS = 1
# Mean CPU per call below which a stream is cheap. Closed-form Python samplers and tests
# cost 3-50 us a call (medians in the examples, the uniform suite and the hidden problems;
# the costliest, tamp2d_4blocks' sample-pose, 80 us), GP-based samplers ~6 ms. A stream's
# first call also pays for cold caches and first-time code paths (+100-250 us measured:
# sample-pose 170-250 us on its first call, test-cfree 254 us then 3-4 us), more on a
# loaded machine. The former 250 us threshold sat inside that noise, so a seed's plan
# changed between runs (tamp2d_4blocks seed 1); 1 ms is four times above it and still far
# below both a GP prediction and the search (0.1-0.4 s) that an optimistic placeholder
# of a stream can waste. Kitchen3D's PyBullet streams span 0.02-1.2 ms (trajectory
# collision tests 0.5-1.2 ms, declared eager there): no threshold is clear of all of them,
# hence the decision is also kept for the solve (docs/results/planner/issue19.md).
AUTO_EAGER_MAX_OVERHEAD_S = 1e-3

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
    """Whether a stream's observed calls show it cheap enough for eager evaluation (and the
    other uses of "cheap": local repairs, probes); the prior does not count.

    Decided once per solve and then kept in ``run.cheap``, so that it does not flip in the
    middle of a solve as the measured mean drifts (a noisy call moved the moment a stream
    became eager, and so the searches): from the persisted ``history`` alone when it has
    :data:`AUTO_EAGER_MIN_CALLS` calls (a fixed input of the solve: the same history, the
    same decision, whatever this run measures), else from this ``run``'s first calls: cheap
    when their mean CPU is below :data:`AUTO_EAGER_MAX_OVERHEAD_S`. Before that, not cheap
    (undecided, nothing kept)."""
    if run is not None and run.cheap is not None:
        return run.cheap
    decision = cheap_decision(history, run)
    if decision is None:
        return False
    if run is not None and run.calls:
        run.cheap = decision
    return decision


def cheap_decision(history: Mapping[str, float] | None, run: StreamStats | None
                   ) -> bool | None:
    """Cheap (``True``), costly (``False``) or undecided (``None``: too few calls), from
    the mean CPU per call of ``history`` when it has at least :data:`AUTO_EAGER_MIN_CALLS`
    calls, else of ``run``, against :data:`AUTO_EAGER_MAX_OVERHEAD_S`."""
    current = {"calls": run.calls, "cpu_s": run.cpu_s} if run is not None else {}
    for source in (history or {}, current):
        if float(source.get("calls", 0.0)) >= AUTO_EAGER_MIN_CALLS:
            return _mean_cpu_us(source) < AUTO_EAGER_MAX_OVERHEAD_S * 1e6
    return None


def _mean_cpu_us(source: Mapping[str, float]) -> float:
    """Mean CPU microseconds per call of ``source`` (which has calls), rounded to
    nanoseconds so that a clock's float steps (1 ms read as 0.999999... ms) do not decide.
    Histories from before CPU time was persisted only have wall time, which bounds it."""
    seconds = float(source.get("cpu_s", source.get("time_s", 0.0)))
    return round(seconds / float(source["calls"]) * 1e6, 3)


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
