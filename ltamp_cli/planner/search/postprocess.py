"""Plan post-processing: greedy action elimination and detour bridging.

Greedy search often leaves detours in a plan (pick an object and put it straight back).
For each action in turn, drop it together with every later action that is no longer
applicable; keep the shorter plan when it still reaches the goal (Nakhost & Müller's greedy
action elimination). Shorter plans also mean fewer stream calls in the focused algorithm.

Elimination cannot remove a detour that some later action needs the side effect of: in
TAMP domains, "move to the cup, pick it, put it back, move on" exists only so that the
robot may move again (``CanMove``), and dropping any part of it breaks the next move. Such
a segment is replaced by one action that leads from the state before it to a state that
agrees with the one after it on every fact the rest of the plan needs (here, moving straight
on) when that action costs no more (:func:`bridge_detours`).
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


def needed_facts(task: Task, plan: list[int]) -> list[frozenset[int]]:
    """For each position ``k`` of ``plan`` (and ``len(plan)``), the basic facts whose truth
    in the state before ``plan[k]`` the rest of the plan and the goal depend on: the facts
    that ``plan[k:]``'s preconditions and effect conditions, and the goal, read (derived
    facts through the bodies of their axioms, transitively) before an action of ``plan[k:]``
    sets or deletes them unconditionally. Two states that agree on ``needed[k]`` let
    ``plan[k:]`` apply alike and reach the goal alike (regression, by induction on ``k``)."""
    bodies: dict[int, list[int]] = {}
    for head, positive, negative in zip(task.axiom_heads, task.axiom_positive,
                                        task.axiom_negative, strict=True):
        bodies.setdefault(head, []).extend((*positive, *negative))
    closure: dict[int, frozenset[int]] = {}

    def basic(facts: list[int]) -> set[int]:
        found: set[int] = set()
        for fact in facts:
            known = closure.get(fact)
            if known is None:
                reached: set[int] = set()
                seen = {fact}
                pending = [fact]
                while pending:
                    current = pending.pop()
                    if current in bodies:
                        for body in bodies[current]:
                            if body not in seen:
                                seen.add(body)
                                pending.append(body)
                    elif not task.is_derived[current]:
                        reached.add(current)
                known = closure[fact] = frozenset(reached)
            found |= known
        return found

    needed = frozenset(basic([task.goal]))
    result = [needed]
    for op_index in reversed(plan):
        op = task.operators[op_index]
        read = [*op.pre_pos, *op.pre_neg]
        for effect in op.conditional:
            read.extend((*effect.condition_pos, *effect.condition_neg))
        needed = frozenset((needed - set(op.adds) - set(op.deletes)) | basic(read))
        result.append(needed)
    result.reverse()
    return result


def bridge_detours(task: Task, plan: list[int], states: list[frozenset[int]]
                   ) -> tuple[list[int], list[frozenset[int]]]:
    """``plan`` (with its ``len(plan) + 1`` states) where a segment is dropped when the
    state before it already agrees with the state after it on every fact the rest of the
    plan needs (:func:`needed_facts`), and a segment of two or more actions is replaced by
    one applicable action, costing no more, whose successor agrees so; the longest such
    segment from each position first. The rest of the plan then stays applicable and reaches
    the goal; its states are recomputed. (Agreeing on the needed facts rather than equal
    states: a greedy plan that stirs the coffee, pours and stirs again has a first stir the
    pour undoes, and dropping its detour leaves a state without ``(Stirred bowl)`` that the
    rest of the plan does not read before the last stir sets it.)"""
    plan, states = list(plan), list(states)
    costs = [op.cost for op in task.operators]
    needed = needed_facts(task, plan)
    position = 0
    while position < len(plan):
        before = states[position]
        # What each segment from here changes that the rest of the plan needs.
        changed = [(states[end + 1] ^ before) & needed[end + 1]
                   for end in range(position, len(plan))]
        dropped = next((end for end in range(len(plan) - 1, position - 1, -1)
                        if not changed[end - position]), None)
        if dropped is not None:
            del plan[position:dropped + 1]
            del needed[position:dropped + 1]
            states[position:] = _states_from(task, before, plan[position:])
            continue
        if position + 1 < len(plan):
            replaced = _bridge(task, plan, needed, position, before, changed, costs)
            if replaced is not None:
                end, op, successor = replaced
                plan[position:end + 1] = [op]
                del needed[position + 1:end + 1]
                states[position + 1:] = _states_from(task, successor, plan[position + 1:])
        position += 1
    return plan, states


def _bridge(task: Task, plan: list[int], needed: list[frozenset[int]], position: int,
            before: frozenset[int], changed: list[frozenset[int]], costs: list[float]
            ) -> tuple[int, int, frozenset[int]] | None:
    """The longest segment ``plan[position:end + 1]`` (two actions or more) that one action
    applicable in ``before`` gets across, costing no more: ``(end, action, its successor)``.
    An action does when, of the facts the rest of the plan needs, it changes exactly those
    the segment changes (``changed[end - position]``)."""
    vector = task.state_vector(before)
    candidates: list[tuple[float, int, frozenset[int], frozenset[int]]] = []
    for op in task.applicable(vector).tolist():
        successor = task.successor(before, vector, op)
        candidates.append((costs[op], op, successor, successor ^ before))
    if not candidates:
        return None
    candidates.sort(key=lambda candidate: candidate[0])
    most = max(len(candidate[3]) for candidate in candidates)
    segment_cost = 0.0
    cumulative = []
    for op in plan[position:]:
        segment_cost += costs[op]
        cumulative.append(segment_cost)
    for end in range(len(plan) - 1, position, -1):
        target = changed[end - position]
        if len(target) > most:
            continue
        relevant = needed[end + 1]
        for cost, op, successor, change in candidates:
            if cost > cumulative[end - position] + 1e-9:
                break
            if target <= change and len(change & relevant) == len(target):
                return end, op, successor
    return None


def _states_from(task: Task, state: frozenset[int], plan: list[int]) -> list[frozenset[int]]:
    """The states of ``plan`` (which applies) from ``state`` on, ``state`` included."""
    states = [state]
    for op in plan:
        state = task.successor(state, task.state_vector(state), op)
        states.append(state)
    return states
