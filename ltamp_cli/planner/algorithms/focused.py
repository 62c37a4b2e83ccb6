"""The focused algorithm: plan with optimistic stream outputs, then sample only what the
plan needs.

Each iteration (1) evaluates streams optimistically up to a complexity bound
(:mod:`.optimistic`); (2) searches over real and optimistic facts; (3) calls the plan's stream
plan in order, binding placeholders to real values. An instance that fails is disabled until
the next search failure, which re-enables everything and raises the complexity bound.
"""

from __future__ import annotations

from ltamp_cli.planner.algorithms.common import PlannerState, bound_plan
from ltamp_cli.planner.algorithms.interleave import (
    InterleavedIncremental,
    interleaved_incremental,
)
from ltamp_cli.planner.algorithms.optimistic import (
    MAX_LOCAL_REPAIRS,
    ContextualStreamPlan,
    Placeholders,
    bind_context,
    bindable_stream_plan,
    contextual_stream_plan,
    evaluate_eager,
    optimistic_evaluation,
    repairable,
    report_unusable,
    sampled_inputs,
    within_limit,
)
from ltamp_cli.planner.algorithms.preimage import plan_preimage
from ltamp_cli.planner.pddl.syntax import StreamFunction
from ltamp_cli.planner.result import INFEASIBLE, SOLVED, TIMEOUT, PlanResult
from ltamp_cli.planner.search.solve import grounding_signature
from ltamp_cli.planner.streams import StreamInstance

# The stream plan made the optimistic plan's facts real, so a plan over real facts is
# usually easy; bound that search so a miss does not turn exhaustive.
REAL_SEARCH_EXPANSIONS = 500


def process_stream_plan(state: PlannerState, entries: ContextualStreamPlan,
                        binding: dict[str, str] | None = None) -> bool:
    """Call the stream plan's entries in order (an entry per instance and state context);
    True when every one succeeded. ``binding`` (filled in when given) maps placeholders to
    the values bound to them.

    When an instance fails, every output this stream plan produced that the failed
    instance consumed is reported unusable to its stream (``Binding.on_unusable``).
    """
    binding = {} if binding is None else binding
    made_by: dict[str, tuple[StreamInstance, tuple[str, ...]]] = {}
    # Per generator position: (instance, index of its next output to use, binding and
    # made_by before it), so that a local repair can go on from its next output.
    sampled: dict[int, tuple[StreamInstance, int, dict[str, str],
                             dict[str, tuple[StreamInstance, tuple[str, ...]]]]] = {}
    repairs = 0
    position = 0
    plan = entries.entries
    while position < len(plan):
        name, inputs = plan[position]
        if state.timed_out():
            return False
        real_inputs = tuple(binding.get(x, x) for x in inputs)
        if any(x.startswith("#") for x in real_inputs):
            return False
        context = bind_context(entries.contexts[position], binding)
        if context is None:
            return False
        instance = state.instance(name, real_inputs, context)
        if instance.disabled:
            return False
        if instance.is_test:
            if instance.num_calls == 0:
                state.call(instance)
            if isinstance(instance.external, StreamFunction) or instance.value:
                position += 1
                continue
            instance.disabled = True
            state.record_failure(instance)
            report_unusable(state, real_inputs, made_by)
            repair = _repair_position(state, sampled, made_by, real_inputs)
            if repair is None or repairs >= MAX_LOCAL_REPAIRS:
                return False
            repairs += 1
            position = repair
            for later in [p for p in sampled if p > position]:
                del sampled[later]
            producer, used, before, made_before = sampled[position]
            binding.clear()
            binding.update(before)
            made_by = dict(made_before)
            output = _output(state, producer, used)
            if output is None:
                return False
            sampled[position] = (producer, used + 1, before, made_before)
            name, inputs = plan[position]
            instance = producer
        else:
            # Called afresh even when it has outputs already (they did not lead to a plan).
            sampled[position] = (instance, len(instance.results) + 1, dict(binding),
                                 dict(made_by))
            outputs = state.call(instance)
            if not outputs:
                instance.disabled = True
                state.record_failure(instance)
                report_unusable(state, real_inputs, made_by)
                return False
            output = outputs[0]
        placeholders = entries.outputs[position]
        binding.update(zip(placeholders, output, strict=True))
        for value in output:
            made_by[value] = (instance, output)
        position += 1
    return True


def _repair_position(state: PlannerState, sampled: dict[int, tuple[StreamInstance, int,
                                                                   dict[str, str], dict]],
                     made_by: dict[str, tuple[StreamInstance, tuple[str, ...]]],
                     rejected: tuple[str, ...]) -> int | None:
    """The stream plan position of the cheap generator that sampled the latest of the
    ``rejected`` values (``None``: none can be repaired)."""
    producers = sampled_inputs(state, rejected, made_by)
    for position in sorted(sampled, reverse=True):
        instance, used, _, _ = sampled[position]
        if instance in producers:
            return position if repairable(state, instance, used) else None
    return None


def _output(state: PlannerState, instance: StreamInstance, index: int
            ) -> tuple[str, ...] | None:
    """Output ``index`` of a generator, calling it once more when it has not made it yet."""
    if index >= len(instance.results) and not instance.exhausted:
        state.call(instance)
    return instance.results[index] if index < len(instance.results) else None


def solve_focused(state: PlannerState, member: InterleavedIncremental | None = None
                  ) -> PlanResult:
    """Focused, interleaved with the incremental algorithm once a grace period passed
    without a plan (:mod:`.interleave`): with ``member`` (the caller's, to run it on after
    an unproven "infeasible"), else with a member made here when one applies."""
    member = member or interleaved_incremental(state)
    result = _solve_focused(state, member)
    return result if member is None else member.annotate(result)


def _solve_focused(state: PlannerState, member: InterleavedIncremental | None) -> PlanResult:
    from ltamp_cli.planner.search.engine import SearchTimeout

    complexity = state.config.initial_complexity
    placeholders = Placeholders()
    capped_task: frozenset[object] | None = None
    try:
        while not state.timed_out():
            if member is not None and (settled := member.run()) is not None:
                return settled
            state.iterations += 1
            evaluate_eager(state)
            evaluation = optimistic_evaluation(state, complexity, placeholders)
            # As in the skeleton algorithms: a task that grounds as the last one whose search
            # ran out of budget is not searched again while the complexity can still grow
            # (kitchen_symbolic seeds 6 and 11: 600, 1,200 and 2,400 expansions of the same
            # task, 2 s of a 3 s solve).
            skip = (capped_task if complexity < state.config.max_complexity
                    + state.max_object_level() else None)
            discrete = state.search(evaluation.index.members, evaluation.object_types,
                                    evaluation.function_values,
                                    context_blocks=evaluation.context_blocks, budgeted=True,
                                    skip_if_grounded_as=skip)
            if discrete.capped and not discrete.skipped:
                capped_task = grounding_signature(discrete.grounding)
            elif not discrete.capped:
                capped_task = None
            if not discrete.solved:
                disabled = [i for i in state.instances.values() if i.disabled]
                if not evaluation.cut and not disabled and not discrete.capped:
                    return state.result(INFEASIBLE, None)
                for instance in disabled:
                    instance.disabled = False
                if evaluation.cut or not disabled:
                    complexity += 1
                if (complexity > state.config.max_complexity + state.max_object_level()
                        and not discrete.capped and not within_limit(state, evaluation)):
                    return state.result(INFEASIBLE, None)
                continue
            facts, terms = plan_preimage(discrete)
            plan = bindable_stream_plan(state, evaluation, facts | terms, placeholders)
            if plan is None:
                continue  # shared placeholders refined: search again
            if not plan:
                return state.result(SOLVED, discrete, facts | terms)
            entries = contextual_stream_plan(state, evaluation, plan, discrete)
            mapping: dict[str, str] = {}
            if process_stream_plan(state, entries, mapping):
                # The stream plan made the optimistic plan's facts real, so the bound
                # optimistic plan is checked first and a plan over real facts is usually
                # easy; bound the search so a miss does not get exhaustive.
                guess = bound_plan(entries.steps, mapping)
                real = state.search(state.facts.members, state.object_types,
                                    state.function_values, REAL_SEARCH_EXPANSIONS,
                                    guess=guess)
                if real.solved:
                    real_facts, real_terms = plan_preimage(real)
                    return state.result(SOLVED, real, real_facts | real_terms)
        return state.result(TIMEOUT, None)
    except SearchTimeout:
        return state.result(TIMEOUT, None)
