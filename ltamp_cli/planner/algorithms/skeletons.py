"""The binding and adaptive algorithms: plan skeletons in a queue (PDDLStream semantics).

A solved optimistic search yields a *skeleton*: the plan with placeholders and the stream
plan that would make it real. Skeletons are kept in a priority queue of partial bindings;
processing a binding calls the next stream instance of its stream plan with the placeholders
bound so far and branches on its outputs (the first output extends the binding, the next one
is tried later as an alternative). A fully bound skeleton is checked by a bounded search over
real facts.

* ``binding`` searches again only when no binding in the queue can progress without more
  retries (alternative outputs, instances that produced nothing) than the current bound;
* ``adaptive`` (the default) also shares effort between searching and sampling: after a
  search it processes a number of bindings proportional to the states the search evaluated,
  then searches again if sampling taught it new facts. A search that finds nothing new
  raises the retry and complexity bounds.
"""

from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass, field

from ltamp_cli.planner.algorithms.common import PlannerState
from ltamp_cli.planner.algorithms.optimistic import (
    InstanceKey,
    bind_context,
    evaluate_eager,
    fluent_contexts,
    optimistic_evaluation,
    report_unusable,
    stream_plan,
)
from ltamp_cli.planner.algorithms.preimage import plan_preimage
from ltamp_cli.planner.pddl.syntax import StreamFunction
from ltamp_cli.planner.result import INFEASIBLE, SOLVED, TIMEOUT, PlanResult
from ltamp_cli.planner.search.engine import SearchTimeout
from ltamp_cli.planner.search.ground import Fact
from ltamp_cli.planner.streams import StreamInstance

REAL_SEARCH_EXPANSIONS = 500
# Sampling effort after a search, in binding steps per state the search evaluated: a work
# measure rather than seconds, so that runs are deterministic for a given seed. A step may
# cost microseconds (a collision test) or seconds (a learned pour with its physics checks), so
# the ratio stays small: 0.5 saved tamp2d_4blocks a few searches (7-10 -> 6-8) but spent the
# Kitchen3D pour_blocked budget on 42 GoodPour calls for stale skeletons (timeout at 90 s,
# where 0.1 plans in ~20 s CPU).
STEPS_PER_EVALUATION = 0.1


@dataclass(frozen=True)
class Skeleton:
    stream_plan: tuple[InstanceKey, ...]
    placeholders: dict[InstanceKey, tuple[str, ...]]
    actions: tuple[str, ...]  # the optimistic plan, for diagnostics
    contexts: dict[InstanceKey, tuple[Fact, ...]] = field(default_factory=dict)


@dataclass
class Binding:
    skeleton: Skeleton
    step: int = 0
    mapping: dict[str, str] = field(default_factory=dict)
    made_by: dict[str, tuple[StreamInstance, tuple[str, ...]]] = field(default_factory=dict)
    output_index: int = 0
    attempts: int = 0

    def priority(self) -> tuple[int, int]:
        return (self.attempts, -self.step)


class BindingQueue:
    def __init__(self) -> None:
        self._heap: list[tuple[tuple[int, int], int, Binding]] = []
        self._counter = itertools.count()

    def push(self, binding: Binding) -> None:
        heapq.heappush(self._heap, (binding.priority(), next(self._counter), binding))

    def pop(self) -> Binding:
        return heapq.heappop(self._heap)[2]

    def peek(self) -> Binding | None:
        return self._heap[0][2] if self._heap else None

    def __len__(self) -> int:
        return len(self._heap)


def advance(state: PlannerState, binding: Binding) -> list[Binding] | None:
    """Process one step of ``binding``: the bindings to queue, or ``None`` when complete."""
    plan = binding.skeleton.stream_plan
    if binding.step >= len(plan):
        return None
    name, inputs = plan[binding.step]
    real_inputs = tuple(binding.mapping.get(x, x) for x in inputs)
    if any(x.startswith("#") for x in real_inputs):
        return []
    context = bind_context(binding.skeleton.contexts.get((name, inputs), ()), binding.mapping)
    if context is None:
        return []
    instance = state.instance(name, real_inputs, context)
    if instance.is_test:
        if instance.num_calls == 0:
            state.call(instance)
        if isinstance(instance.external, StreamFunction) or instance.value:
            return [Binding(binding.skeleton, binding.step + 1, binding.mapping,
                            binding.made_by, 0, binding.attempts)]
        state.record_failure(instance)
        report_unusable(state, real_inputs, binding.made_by)
        return []
    if binding.output_index >= len(instance.results) and not instance.exhausted:
        state.call(instance)
    if binding.output_index < len(instance.results):
        output = instance.results[binding.output_index]
        placeholders = binding.skeleton.placeholders.get((name, inputs), ())
        mapping = {**binding.mapping, **dict(zip(placeholders, output, strict=True))}
        made_by = {**binding.made_by, **{o: (instance, output) for o in output}}
        child = Binding(binding.skeleton, binding.step + 1, mapping, made_by, 0,
                        binding.attempts)
        alternative = Binding(binding.skeleton, binding.step, binding.mapping,
                              binding.made_by, binding.output_index + 1, binding.attempts + 1)
        return [child, alternative]
    if instance.exhausted:
        state.record_failure(instance)
        report_unusable(state, real_inputs, binding.made_by)
        return []
    binding.attempts += 1  # nothing this call: retry later
    return [binding]


def solve_with_skeletons(state: PlannerState, adaptive: bool) -> PlanResult:
    complexity = state.config.initial_complexity
    placeholders: dict[InstanceKey, tuple[str, ...]] = {}
    queue = BindingQueue()
    seen_skeletons: set[tuple[object, ...]] = set()
    last_search_work = 0
    retry_threshold = 0
    facts_at_search = -1
    try:
        while not state.timed_out():
            state.iterations += 1
            evaluate_eager(state)
            head = queue.peek()
            stalled = head is None or head.attempts > retry_threshold
            learned = len(state.facts.members) != facts_at_search
            if stalled or (adaptive and learned):
                facts_at_search = len(state.facts.members)
                evaluation = optimistic_evaluation(state, complexity, placeholders)
                discrete = state.search(evaluation.index.members, evaluation.object_types,
                                        evaluation.function_values,
                                        context_blocks=evaluation.context_blocks,
                                        budgeted=True)
                last_search_work = discrete.outcome.evaluated if discrete.outcome else 0
                state.diagnose(discrete, evaluation.index.members)
                if discrete.solved:
                    facts, terms = plan_preimage(discrete)
                    plan = tuple(stream_plan(state, evaluation, facts | terms))
                    if not plan:
                        return state.result(SOLVED, discrete, facts | terms)
                    state.remember_skeleton([str(a) for a in discrete.actions or []])
                    contexts = fluent_contexts(state, evaluation, discrete)
                    signature = (plan, tuple(sorted(contexts.items())))
                    if signature not in seen_skeletons:
                        seen_skeletons.add(signature)
                        queue.push(Binding(Skeleton(
                            plan, dict(evaluation.outputs),
                            tuple(str(a) for a in discrete.actions or []), contexts)))
                    elif stalled:
                        # Nothing new to try at this bound: allow more retries and
                        # more complex optimistic values.
                        retry_threshold += 1
                        complexity += 1
                else:
                    if not evaluation.cut and not len(queue) and not discrete.capped:
                        return state.result(INFEASIBLE, None)
                    retry_threshold += 1
                    complexity += 1
                    if (complexity > state.config.max_complexity and not len(queue)
                            and not discrete.capped):
                        return state.result(INFEASIBLE, None)
            steps = max(1, round(last_search_work * STEPS_PER_EVALUATION))
            result = _process(state, queue, adaptive, steps, retry_threshold)
            if result is not None:
                return result
        return state.result(TIMEOUT, None)
    except SearchTimeout:
        return state.result(TIMEOUT, None)


def _process(state: PlannerState, queue: BindingQueue, adaptive: bool, steps: int,
             retry_threshold: int) -> PlanResult | None:
    done = 0
    while len(queue) and not state.timed_out():
        head = queue.peek()
        assert head is not None
        if adaptive and done >= steps:
            return None
        done += 1
        if head.attempts > retry_threshold:
            return None
        binding = queue.pop()
        children = advance(state, binding)
        if children is None:
            real = state.search(state.facts.members, state.object_types,
                                state.function_values, REAL_SEARCH_EXPANSIONS)
            if real.solved:
                facts, terms = plan_preimage(real)
                return state.result(SOLVED, real, facts | terms)
            continue
        for child in children:
            queue.push(child)
    return None
