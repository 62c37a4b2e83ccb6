"""Plan post-processing: greedy action elimination and detour bridging.

Greedy search often leaves detours in a plan (pick an object and put it straight back).
For each action in turn, drop it together with every later action that is no longer
applicable; keep the shorter plan when it still reaches the goal (Nakhost & Müller's greedy
action elimination). Shorter plans also mean fewer stream calls in the focused algorithm.

Elimination cannot remove a detour that some later action needs the side effect of: in
TAMP domains, "move to the cup, pick it, put it back, move on" exists only so that the
robot may move again (``CanMove``), and dropping any part of it breaks the next move. Such
a segment is replaced by one action that leads from the state before it to the state
after it (here, moving straight on) when that action costs no more (:func:`bridge_detours`).
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
    return _simulate_from(task, task.init, plan, skip)


def _simulate_from(task: Task, state: frozenset[int], plan: list[int], skip: set[int]
                   ) -> tuple[list[int], list[frozenset[int]], bool]:
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
    # Every action of ``current`` is applicable in turn (the plan is valid, and a shortened
    # plan keeps only the actions that applied), so dropping the action at ``position``
    # leaves the states before it unchanged: each try is simulated from there.
    _, states, reaches_goal = simulate(task, current, set())
    assert reaches_goal and len(states) == len(current) + 1, "the plan must be valid"
    position = 0
    while position < len(current):
        kept, tail, reaches_goal = _simulate_from(task, states[position],
                                                  current[position + 1:], set())
        if reaches_goal:
            current = current[:position] + [current[position + 1 + i] for i in kept]
            states = states[:position + 1] + tail[1:]
        else:
            position += 1
    return current, states


# Longest segment (in actions) that :func:`bridge_detours` tries to replace by one action.
MAX_BRIDGED_SEGMENT = 6


def bridge_detours(task: Task, plan: list[int], states: list[frozenset[int]],
                   max_segment: int = MAX_BRIDGED_SEGMENT
                   ) -> tuple[list[int], list[frozenset[int]]]:
    """``plan`` (with its ``len(plan) + 1`` states) where every segment of 2 to
    ``max_segment`` actions that one applicable action, costing no more, also gets across
    (same state after it) is replaced by that action, and every segment that returns to the
    state before it is dropped. The states after the segment are unchanged, so the rest of
    the plan stays valid without being simulated."""
    plan, states = list(plan), list(states)
    costs = [op.cost for op in task.operators]
    position = 0
    while position < len(plan):
        before = states[position]
        last = min(len(plan), position + max_segment) - 1
        returns = [end for end in range(last, position - 1, -1) if states[end + 1] == before]
        if returns:
            end = returns[0]
            del plan[position:end + 1]
            del states[position + 1:end + 2]
            continue
        if last > position:
            vector = task.state_vector(before)
            reached: dict[frozenset[int], int] = {}
            for op in task.applicable(vector).tolist():
                reached.setdefault(task.successor(before, vector, op), op)
            for end in range(last, position, -1):
                op = reached.get(states[end + 1])
                if op is not None and costs[op] <= sum(costs[i] for i in
                                                       plan[position:end + 1]) + 1e-9:
                    plan[position:end + 1] = [op]
                    del states[position + 1:end + 1]
                    break
        position += 1
    return plan, states
