"""Plan post-processing: greedy action elimination.

Greedy search often leaves detours in a plan (pick an object and put it straight back).
For each action in turn, drop it together with every later action that is no longer
applicable; keep the shorter plan when it still reaches the goal (Nakhost & Müller's greedy
action elimination). Shorter plans also mean fewer stream calls in the focused algorithm.
"""

from __future__ import annotations

from ltamp_cli.planner.search.task import Task


def is_applicable(task: Task, vector, op_index: int) -> bool:  # type: ignore[no-untyped-def]
    op = task.operators[op_index]
    return all(vector[f] for f in op.pre_pos) and not any(vector[f] for f in op.pre_neg)


def simulate(task: Task, plan: list[int], skip: set[int]
             ) -> tuple[list[int], list[frozenset[int]], bool]:
    """Run ``plan`` without the ``skip`` positions, also skipping actions that became
    inapplicable. Returns the kept positions, the visited states and whether the goal holds."""
    state = task.init
    states = [state]
    kept: list[int] = []
    for position, op in enumerate(plan):
        if position in skip:
            continue
        vector = task.state_vector(state)
        if not is_applicable(task, vector, op):
            continue
        state = task.successor(state, vector, op)
        states.append(state)
        kept.append(position)
    return kept, states, task.is_goal(task.state_vector(state))


def eliminate_redundant_actions(task: Task, plan: list[int]
                                ) -> tuple[list[int], list[frozenset[int]]]:
    """A valid sub-plan of ``plan`` with detours removed, and its states."""
    current = list(plan)
    position = 0
    while position < len(current):
        kept, _, reaches_goal = simulate(task, current, {position})
        if reaches_goal:
            current = [current[i] for i in kept]
        else:
            position += 1
    _, states, reaches_goal = simulate(task, current, set())
    assert reaches_goal, "action elimination must keep the plan valid"
    return current, states
