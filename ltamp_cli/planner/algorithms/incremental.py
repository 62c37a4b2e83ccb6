"""The incremental algorithm: alternate calling every stream instance and searching.

Complete for problems whose streams eventually produce the needed values: every legal
stream instance is called once per iteration, so all reachable values appear level by level
(eager streams, ``StreamInfo.eager``, are evaluated to a fixpoint at the start of each
iteration).
"""

from __future__ import annotations

from collections.abc import Generator

from ltamp_cli.planner.algorithms.common import PlannerState
from ltamp_cli.planner.algorithms.optimistic import evaluate_eager_steps
from ltamp_cli.planner.algorithms.preimage import plan_preimage
from ltamp_cli.planner.result import INFEASIBLE, SOLVED, TIMEOUT, PlanResult
from ltamp_cli.planner.search.engine import SearchTimeout


def solve_incremental(state: PlannerState) -> PlanResult:
    """Run :func:`incremental_steps` to its result."""
    steps = incremental_steps(state)
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value


def incremental_steps(state: PlannerState) -> Generator[None, None, PlanResult]:
    """The incremental algorithm as a resumable computation: yields after every stream call
    and every search (so that another algorithm can interleave it in bounded slices, see
    :mod:`.interleave`) and returns the result (``StopIteration.value``)."""
    changed = True
    capped = False
    try:
        while True:
            state.iterations += 1
            # Eager streams (cheap, decisive: kinematics, collision tests) are evaluated on
            # every real input to a fixpoint, as the other algorithms do, rather than one
            # level per iteration: a new sample is then usable in the very next search
            # (tamp2d_4blocks 5-7 -> 3-5 searches; kitchen_symbolic 4-6 -> 2-3).
            before = _sizes(state)
            yield from evaluate_eager_steps(state)
            changed = changed or _sizes(state) != before
            if changed:
                discrete = state.search(state.facts.members, state.object_types,
                                        state.function_values, budgeted=True)
                if discrete.solved:
                    facts, terms = plan_preimage(discrete)
                    return state.result(SOLVED, discrete, facts | terms)
                capped = discrete.capped
                yield
            if state.timed_out():
                return state.result(TIMEOUT, None)
            # A search stopped by its budget proves nothing: search again (with a larger
            # budget) even when sampling adds nothing.
            changed = (yield from _sample_all_steps(state)) or capped
            if not changed and all(i.exhausted for i in state.instances.values()):
                return state.result(INFEASIBLE, None)
    except SearchTimeout:
        return state.result(TIMEOUT, None)


def sample_all(state: PlannerState) -> bool:
    """Create every new legal instance, then call each non-exhausted one once."""
    steps = _sample_all_steps(state)
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return bool(done.value)


def _sample_all_steps(state: PlannerState) -> Generator[None, None, bool]:
    """:func:`sample_all`, yielding after each call; returns whether facts were added."""
    # Streams with :fluents see the initial state here (incremental plans are not
    # interleaved with sampling, so no later state is known when they are called).
    initial = [(atom.predicate, *atom.args) for atom in state.problem.init]
    for external in state.externals.values():
        context = state.fluent_context(external.name, initial)
        for inputs in state.new_bindings(external, "incremental"):
            state.instance(external.name, inputs, context)
    before = _sizes(state)
    for instance in list(state.instances.values()):
        if state.timed_out():
            break
        if not instance.exhausted:
            state.call(instance)
            yield
    return _sizes(state) != before


def _sizes(state: PlannerState) -> tuple[int, int]:
    """Known facts and function values: both only grow."""
    return len(state.facts.members), len(state.function_values)
