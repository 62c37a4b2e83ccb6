"""Heuristic search engines: lazy greedy best-first with preferred operators, weighted A*."""

from __future__ import annotations

import heapq
import itertools
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

from ltamp_cli.planner.search.clock import SearchTimeout
from ltamp_cli.planner.search.heuristic import INFINITY, FFHeuristic
from ltamp_cli.planner.search.postprocess import (
    bridge_detours,
    eliminate_redundant_actions,
    is_applicable,
)
from ltamp_cli.planner.search.task import Task

# "fd"/"fd-wastar": Fast Downward subprocesses (optional extra, search/fast_downward.py).
SEARCH_ALGORITHMS = ("ff", "lazy-greedy", "wastar", "fd", "fd-wastar")
LOCAL_EXPANSIONS = 5000


@dataclass
class SearchOutcome:
    plan: list[int] | None  # operator indices
    cost: float
    expanded: int
    evaluated: int
    time_s: float
    states: list[frozenset[int]] = field(default_factory=list)
    # No plan because the expansion budget ran out (not because the space was exhausted).
    capped: bool = False
    # The plan is the caller's guess (:func:`follow_plan`): no search ran.
    guessed: bool = False


def _reconstruct(parents: dict, state: frozenset[int]) -> tuple[list[int], list[frozenset[int]]]:
    ops: list[int] = []
    states = [state]
    while parents[state] is not None:
        parent, op = parents[state]
        ops.append(op)
        states.append(parent)
        state = parent
    return ops[::-1], states[::-1]


def lazy_greedy(task: Task, deadline: float, boost: int = 1000,
                unit_costs: bool = False, initial: frozenset[int] | None = None,
                heuristic: FFHeuristic | None = None, max_expansions: int | None = None
                ) -> SearchOutcome:
    """FD-style lazy GBFS with the FF heuristic and a boosted preferred-operator queue.

    Starts from ``initial`` (default: the task's initial state); gives up (plan ``None``)
    after ``max_expansions`` expansions when that is set.
    """
    start_time = time.perf_counter()
    heuristic = heuristic or FFHeuristic(task, unit_costs=unit_costs)
    counter = itertools.count()
    root = task.init if initial is None else initial
    parents: dict[frozenset[int], tuple[frozenset[int], int] | None] = {root: None}
    g_values = {root: 0.0}
    queues: list[list] = [[], []]  # regular, preferred
    priorities = [0, boost]
    best_h = INFINITY
    expanded = evaluated = 0

    def evaluate_and_expand(state: frozenset[int]) -> SearchOutcome | None:
        nonlocal best_h, expanded, evaluated
        vector = task.state_vector(state)
        if task.is_goal(vector):
            ops, states = _reconstruct(parents, state)
            return SearchOutcome(ops, g_values[state], expanded, evaluated,
                                 time.perf_counter() - start_time, states)
        evaluated += 1
        applicable = task.applicable(vector)
        if not len(applicable):
            # No successor, so a dead end whatever h says; checked before h because TAMP
            # domains make many (a move to a configuration where nothing can be picked or
            # placed): 2,842 of 4,446 evaluations in a tamp2d_4blocks focused run.
            return None
        result = heuristic(vector)
        if result.value == INFINITY:
            return None
        expanded += 1
        if result.value < best_h:
            best_h = result.value
            priorities[1] += boost
        preferred = set(result.preferred)
        ordered = [*(i for i in applicable if i in preferred),
                   *(i for i in applicable if i not in preferred)]
        for op in ordered:
            entry = (result.value, next(counter), state, int(op), vector)
            heapq.heappush(queues[0], entry)
            if op in preferred:
                heapq.heappush(queues[1], entry)
        return None

    outcome = evaluate_and_expand(root)
    if outcome is not None:
        return outcome
    while queues[0] or queues[1]:
        if time.perf_counter() > deadline:
            raise SearchTimeout
        if max_expansions is not None and expanded > max_expansions:
            return SearchOutcome(None, INFINITY, expanded, evaluated,
                                 time.perf_counter() - start_time, capped=True)
        which = 1 if queues[1] and priorities[1] >= priorities[0] else 0
        if not queues[which]:
            which = 1 - which
        _, _, parent, op, parent_vector = heapq.heappop(queues[which])
        priorities[which] -= 1
        child = task.successor(parent, parent_vector, op)
        if child in parents:
            continue
        parents[child] = (parent, op)
        g_values[child] = g_values[parent] + task.operators[op].cost
        outcome = evaluate_and_expand(child)
        if outcome is not None:
            return outcome
    return SearchOutcome(None, INFINITY, expanded, evaluated, time.perf_counter() - start_time)


def weighted_astar(task: Task, deadline: float, weight: float = 2.0,
                   cost_bound: float | None = None, unit_costs: bool = False) -> SearchOutcome:
    """Eager weighted A* on real action costs with the FF heuristic (reopening closed);
    ``unit_costs``: every action costs 1 (the plan's cost is its length).

    With ``cost_bound``, only plans cheaper than the bound are accepted (paths reaching it are
    pruned): the anytime mode's "find a better plan", in the unit the solve measures costs.
    """
    start_time = time.perf_counter()
    heuristic = FFHeuristic(task, cost_bias=0.0, unit_costs=unit_costs)
    counter = itertools.count()
    parents: dict[frozenset[int], tuple[frozenset[int], int] | None] = {task.init: None}
    g_values = {task.init: 0.0}
    vector = task.state_vector(task.init)
    h0 = heuristic(vector).value
    expanded = evaluated = 1
    if h0 == INFINITY:
        return SearchOutcome(None, INFINITY, 0, 1, time.perf_counter() - start_time)
    queue = [(weight * h0, h0, next(counter), task.init)]
    closed: set[frozenset[int]] = set()
    while queue:
        if time.perf_counter() > deadline:
            raise SearchTimeout
        _, _, _, state = heapq.heappop(queue)
        if state in closed:
            continue
        closed.add(state)
        vector = task.state_vector(state)
        if task.is_goal(vector):
            ops, states = _reconstruct(parents, state)
            return SearchOutcome(ops, g_values[state], expanded, evaluated,
                                 time.perf_counter() - start_time, states)
        expanded += 1
        for op in task.applicable(vector):
            child = task.successor(state, vector, int(op))
            g = g_values[state] + (1.0 if unit_costs else task.operators[op].cost)
            if cost_bound is not None and g >= cost_bound - 1e-9:
                continue
            if child in g_values and g_values[child] <= g:
                continue
            g_values[child] = g
            parents[child] = (state, int(op))
            closed.discard(child)
            child_h = heuristic(task.state_vector(child)).value
            evaluated += 1
            if child_h == INFINITY:
                continue
            heapq.heappush(queue, (g + weight * child_h, child_h, next(counter), child))
    return SearchOutcome(None, INFINITY, expanded, evaluated, time.perf_counter() - start_time)


def enforced_hill_climbing(task: Task, deadline: float, unit_costs: bool = False,
                           heuristic: FFHeuristic | None = None,
                           max_expansions: int | None = None) -> SearchOutcome | None:
    """FF's enforced hill-climbing over helpful actions; ``None`` when it gets stuck.

    From the current state, breadth-first search (helpful actions only) for a state with a
    strictly better heuristic value, commit to it, repeat until the goal holds. The greedy
    search that escapes a plateau expands at most ``max_expansions`` states when that is set.
    """
    from collections import deque

    start_time = time.perf_counter()
    heuristic = heuristic or FFHeuristic(task, unit_costs=unit_costs)
    expanded = evaluated = 0
    state = task.init
    vector = task.state_vector(state)
    result = heuristic(vector)
    evaluated += 1
    if result.value == INFINITY:
        return None
    path_ops: list[int] = []
    path_states = [state]
    seen = {state}
    while not task.is_goal(vector):
        best = result.value
        queue = deque([(state, vector, result.preferred, [])])
        found = None
        while queue and found is None:
            if time.perf_counter() > deadline:
                raise SearchTimeout
            parent, parent_vector, helpful, ops = queue.popleft()
            expanded += 1
            # Relaxed plans ignore negative preconditions: keep only really applicable ones
            # (checked per helpful operator: a few, where the task has hundreds).
            for op in (op for op in helpful if is_applicable(task, parent_vector, op)):
                child = task.successor(parent, parent_vector, op)
                if child in seen:
                    continue
                seen.add(child)
                child_vector = task.state_vector(child)
                if task.is_goal(child_vector):
                    found = (child, child_vector, None, [*ops, op])
                    break
                child_result = heuristic(child_vector)
                evaluated += 1
                if child_result.value == INFINITY:
                    continue
                if child_result.value < best:
                    found = (child, child_vector, child_result, [*ops, op])
                    break
                queue.append((child, child_vector, child_result.preferred, [*ops, op]))
        if found is None:
            # Stuck on a plateau that helpful actions cannot leave: a budgeted greedy
            # search from here usually escapes it; else report failure.
            budget = LOCAL_EXPANSIONS
            if max_expansions is not None:
                budget = min(budget, max_expansions)
            local = lazy_greedy(task, deadline, initial=state, heuristic=heuristic,
                                max_expansions=budget)
            if local.plan is None:
                return None
            path_ops.extend(local.plan)
            path_states.extend(local.states[1:])
            expanded += local.expanded
            evaluated += local.evaluated
            break
        state, vector, next_result, ops = found
        for op in ops:
            path_states.append(task.successor(path_states[-1], task.state_vector(path_states[-1]),
                                              op))
        path_ops.extend(ops)
        if next_result is None:
            break
        result = next_result
    cost = float(sum(task.operators[i].cost for i in path_ops))
    return SearchOutcome(path_ops, cost, expanded, evaluated, time.perf_counter() - start_time,
                         path_states)


def follow_plan(task: Task, guess: Sequence[tuple[str, tuple[str, ...]]]
                ) -> SearchOutcome | None:
    """``guess`` (action names and arguments) as an outcome when it is applicable step by
    step in ``task`` and reaches the goal; ``None`` otherwise. An action grounded into
    several operators (e.g. one per disjunct) uses the first applicable one."""
    start_time = time.perf_counter()
    by_name: dict[tuple[str, tuple[str, ...]], list[int]] = {}
    for index, op in enumerate(task.operators):
        by_name.setdefault((op.action.name, op.action.args), []).append(index)
    state = task.init
    states = [state]
    ops: list[int] = []
    for step in guess:
        vector = task.state_vector(state)
        applicable = [i for i in by_name.get(step, ()) if is_applicable(task, vector, i)]
        if not applicable:
            return None
        ops.append(applicable[0])
        state = task.successor(state, vector, applicable[0])
        states.append(state)
    if not task.is_goal(task.state_vector(state)):
        return None
    cost = float(sum(task.operators[i].cost for i in ops))
    return SearchOutcome(ops, cost, 0, 0, time.perf_counter() - start_time, states,
                         guessed=True)


def run_search(task: Task, algorithm: str, deadline: float, unit_costs: bool = False,
               max_expansions: int | None = None,
               guess: Sequence[tuple[str, tuple[str, ...]]] | None = None) -> SearchOutcome:
    """Search ``task``, then remove detours from the plan found.

    ``max_expansions`` bounds the greedy searches (they are incomplete then). A ``guess``
    that is a valid plan of ``task`` (:func:`follow_plan`) is used without searching: the
    binding algorithms pass the optimistic plan with its placeholders bound, which the
    stream plan just made real (PDDLStream returns that plan directly).
    """
    outcome = follow_plan(task, guess) if guess is not None else None
    if outcome is None:
        outcome = _search(task, algorithm, deadline, unit_costs, max_expansions)
    if outcome.plan is not None and algorithm != "wastar":
        outcome.plan, outcome.states = eliminate_redundant_actions(task, outcome.plan)
        outcome.plan, outcome.states = bridge_detours(task, outcome.plan, outcome.states)
        outcome.cost = float(sum(task.operators[i].cost for i in outcome.plan))
    return outcome


def _search(task: Task, algorithm: str, deadline: float, unit_costs: bool,
            max_expansions: int | None) -> SearchOutcome:
    if algorithm == "ff":
        # One heuristic (and its memo) for hill-climbing and the greedy fallback.
        heuristic = FFHeuristic(task, unit_costs=unit_costs)
        outcome = enforced_hill_climbing(task, deadline, unit_costs=unit_costs,
                                         heuristic=heuristic, max_expansions=max_expansions)
        if outcome is not None:
            return outcome
        return lazy_greedy(task, deadline, unit_costs=unit_costs, heuristic=heuristic,
                           max_expansions=max_expansions)
    if algorithm == "lazy-greedy":
        return lazy_greedy(task, deadline, unit_costs=unit_costs, max_expansions=max_expansions)
    if algorithm == "wastar":
        return weighted_astar(task, deadline)
    if algorithm in ("fd", "fd-wastar"):
        from ltamp_cli.planner.search.fast_downward import search_with_fast_downward

        return search_with_fast_downward(task, deadline, algorithm, unit_costs)
    raise ValueError(f"unknown search algorithm {algorithm!r}; expected one of "
                     f"{', '.join(SEARCH_ALGORITHMS)}")



