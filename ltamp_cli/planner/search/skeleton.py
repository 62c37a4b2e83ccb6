"""Plan constraints: make the plan follow a given skeleton of action patterns.

A skeleton is a sequence of patterns, each ``"NAME ARG ..."`` where an argument may be ``?``
(any object), ``"*"`` (any one action) or ``"..."`` (any number of actions, possibly none).
It is compiled into the grounded task with a step counter ``(%step i)``: an action matching
pattern ``i`` moves the counter from ``i`` to ``i + 1``; ``...`` lets any action keep it; the
goal requires the counter at the end.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

from ltamp_cli.errors import InputError
from ltamp_cli.planner.search.ground import Fact, GroundAction, GroundAxiom, GroundEffect, Grounding
from ltamp_cli.planner.search.normalize import GOAL_PREDICATE

STEP = "%step"
ANY_ACTION, ANY_SEQUENCE, ANY_ARG = "*", "...", "?"


@dataclass(frozen=True)
class Pattern:
    name: str  # "*" for any action
    args: tuple[str, ...] | None  # None: any arguments

    def matches(self, action: GroundAction) -> bool:
        if self.name != ANY_ACTION and self.name != action.name:
            return False
        if self.args is None:
            return True
        return len(self.args) == len(action.args) and all(
            p in (ANY_ARG, a) for p, a in zip(self.args, action.args, strict=True))


def parse_skeleton(entries: Sequence[str]) -> tuple[list[Pattern], list[bool]]:
    """Patterns and, for each of the ``len(patterns) + 1`` gaps, whether ``...`` is there."""
    patterns: list[Pattern] = []
    gaps = [False]
    for entry in entries:
        words = str(entry).lower().split()
        if not words:
            raise InputError("an empty skeleton entry: expected an action pattern, '*' or '...'")
        if words == [ANY_SEQUENCE]:
            gaps[-1] = True
            continue
        name, args = words[0], tuple(words[1:])
        patterns.append(Pattern(name, args or None if name != ANY_ACTION else None))
        gaps.append(False)
    return patterns, gaps


def step_fact(index: int) -> Fact:
    return (STEP, str(index))


def constrain(grounding: Grounding, entries: Sequence[str]) -> tuple[Grounding, Fact]:
    """The grounding restricted to plans that follow the skeleton, and its initial step fact."""
    patterns, gaps = parse_skeleton(entries)
    actions: list[GroundAction] = []
    for action in grounding.actions:
        for index, pattern in enumerate(patterns):
            if pattern.matches(action):
                actions.append(_at_step(action, index, index + 1))
        for index, open_gap in enumerate(gaps):
            if open_gap:
                actions.append(_at_step(action, index, index))
    end = step_fact(len(patterns))
    axioms = [
        GroundAxiom(a.head, (*a.body_pos, end), a.body_neg, a.static_pos)
        if a.head == (GOAL_PREDICATE,) else a
        for a in grounding.axioms
    ]
    constrained = replace(grounding, actions=actions, axioms=axioms,
                          reachable=grounding.reachable | {step_fact(i) for i in
                                                           range(len(patterns) + 1)})
    return constrained, step_fact(0)


def _at_step(action: GroundAction, before: int, after: int) -> GroundAction:
    if before == after:
        return replace(action, pre_pos=(*action.pre_pos, step_fact(before)))
    effects = (*action.effects,
               GroundEffect((), (), step_fact(before), False),
               GroundEffect((), (), step_fact(after), True))
    return replace(action, pre_pos=(*action.pre_pos, step_fact(before)), effects=effects)
