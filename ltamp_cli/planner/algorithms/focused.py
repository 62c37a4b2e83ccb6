"""The focused algorithm: plan with optimistic stream outputs, then sample only what the
plan needs.

Each iteration (1) evaluates streams optimistically up to a complexity bound
(:mod:`.optimistic`); (2) searches over real and optimistic facts; (3) calls the plan's stream
plan in order, binding placeholders to real values. An instance that fails is disabled until
the next search failure, which re-enables everything and raises the complexity bound.
"""

from __future__ import annotations

from ltamp_cli.planner.algorithms.common import PlannerState
from ltamp_cli.planner.algorithms.optimistic import (
    InstanceKey,
    OptimisticEvaluation,
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
from ltamp_cli.planner.search.ground import Fact
from ltamp_cli.planner.streams import StreamInstance

# The stream plan made the optimistic plan's facts real, so a plan over real facts is
# usually easy; bound that search so a miss does not turn exhaustive.
REAL_SEARCH_EXPANSIONS = 500


def process_stream_plan(state: PlannerState, evaluation: OptimisticEvaluation,
                        plan: list[InstanceKey],
                        contexts: dict[InstanceKey, tuple[Fact, ...]] | None = None) -> bool:
    """Call the stream plan in order; True when every instance succeeded.

    When an instance fails, every output this stream plan produced that the failed
    instance consumed is reported unusable to its stream (``Binding.on_unusable``).
    """
    binding: dict[str, str] = {}
    made_by: dict[str, tuple[StreamInstance, tuple[str, ...]]] = {}
    for name, inputs in plan:
        if state.timed_out():
            return False
        real_inputs = tuple(binding.get(x, x) for x in inputs)
        if any(x.startswith("#") for x in real_inputs):
            return False
        context = bind_context((contexts or {}).get((name, inputs), ()), binding)
        if context is None:
            return False
        instance = state.instance(name, real_inputs, context)
        if instance.disabled:
            return False
        if instance.is_test:
            if instance.num_calls == 0:
                state.call(instance)
            if isinstance(instance.external, StreamFunction) or instance.value:
                continue
            instance.disabled = True
            state.record_failure(instance)
            report_unusable(state, real_inputs, made_by)
            return False
        outputs = state.call(instance)
        if not outputs:
            instance.disabled = True
            state.record_failure(instance)
            report_unusable(state, real_inputs, made_by)
            return False
        placeholders = evaluation.outputs.get((name, inputs), ())
        binding.update(zip(placeholders, outputs[0], strict=True))
        for output in outputs[0]:
            made_by[output] = (instance, outputs[0])
    return True


def solve_focused(state: PlannerState) -> PlanResult:
    from ltamp_cli.planner.search.engine import SearchTimeout

    complexity = state.config.initial_complexity
    placeholders: dict[InstanceKey, tuple[str, ...]] = {}
    try:
        while not state.timed_out():
            state.iterations += 1
            evaluate_eager(state)
            evaluation = optimistic_evaluation(state, complexity, placeholders)
            discrete = state.search(evaluation.index.members, evaluation.object_types,
                                    evaluation.function_values,
                                    context_blocks=evaluation.context_blocks, budgeted=True)
            if not discrete.solved:
                disabled = [i for i in state.instances.values() if i.disabled]
                if not evaluation.cut and not disabled and not discrete.capped:
                    return state.result(INFEASIBLE, None)
                for instance in disabled:
                    instance.disabled = False
                if evaluation.cut or not disabled:
                    complexity += 1
                if complexity > state.config.max_complexity and not discrete.capped:
                    return state.result(INFEASIBLE, None)
                continue
            facts, terms = plan_preimage(discrete)
            plan = stream_plan(state, evaluation, facts | terms)
            if not plan:
                return state.result(SOLVED, discrete, facts | terms)
            contexts = fluent_contexts(state, evaluation, discrete)
            if process_stream_plan(state, evaluation, plan, contexts):
                # The stream plan made the optimistic plan's facts real, so a plan over real
                # facts is usually easy; bound the search so a miss does not get exhaustive.
                real = state.search(state.facts.members, state.object_types,
                                    state.function_values, REAL_SEARCH_EXPANSIONS)
                if real.solved:
                    real_facts, real_terms = plan_preimage(real)
                    return state.result(SOLVED, real, real_facts | real_terms)
        return state.result(TIMEOUT, None)
    except SearchTimeout:
        return state.result(TIMEOUT, None)
