"""Plan constraints: make the plan follow one of a set of skeletons (PDDLStream's
``PlanConstraints``).

A skeleton is a set of *steps*, each an action pattern (a name, or ``*`` for any action,
and one pattern per argument), partially ordered: ``orders`` holds pairs ``(i, j)`` (step
``i`` before step ``j``) and ``(i, GOAL)`` (step ``i`` must be done when the plan ends). An
argument pattern is ``None`` (any object), a variable ``"?x"`` (every step of the skeleton
that names ``?x`` takes the same object; twice in one step, the same object twice) or a
set of object names (one of them: a constant, or PDDLStream's ``groups``). *Gaps* say where
other actions may come: a linear skeleton has one flag per gap (before its first step,
between two steps, after its last); ``exact`` in PDDLStream closes them all, otherwise all
are open (the skeleton is a subsequence of the plan).

The command line and YAML write a linear skeleton as a list of strings, ``"NAME ARG ..."``
with ``?`` for any argument, ``?x`` for a variable, ``*`` for any one action and ``...`` for
an open gap (:func:`parse_skeleton`).

Compiled into the grounded task as PDDLStream compiles it into its PDDL task: each ground
action that matches step ``i`` of skeleton ``k`` gets a copy that requires the steps
ordered before ``i`` done and ``i`` not yet done, and marks ``i`` done; a variable first
bound by the step records its object (``%skeleton-assigned``) and later steps require the
same one; no step of another skeleton may follow. The goal additionally requires some
skeleton complete (all its steps ordered before ``GOAL`` done). Other actions keep their
own form where every gap is open, and get a copy bound to the gap otherwise.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, replace
from itertools import product

from ltamp_cli.errors import InputError
from ltamp_cli.planner.search.ground import Fact, GroundAction, GroundAxiom, GroundEffect, Grounding
from ltamp_cli.planner.search.normalize import GOAL_PREDICATE

GOAL = -1  # the end of the plan, as an ``orders`` target
ANY_ACTION, ANY_SEQUENCE, ANY_ARG = "*", "...", "?"
DONE = "%skeleton-done"  # (DONE k i): step i of skeleton k was taken
BOUND = "%skeleton-bound"  # (BOUND k ?x): a step of skeleton k bound the variable ?x
ASSIGNED = "%skeleton-assigned"  # (ASSIGNED k ?x obj): ... to obj
COMPLETE = "%skeleton-complete"  # derived: some skeleton has all its final steps done
STARTED = "%skeleton-started"  # (STARTED k): a step of skeleton k was taken

# An argument pattern: None (any object), "?name" (a variable) or a set of object names.
ArgPattern = str | frozenset[str] | None


@dataclass(frozen=True)
class StepPattern:
    """One step: an action ``name`` (``*``: any) and its argument patterns (``None``: any
    arguments)."""

    name: str
    args: tuple[ArgPattern, ...] | None = None

    def match(self, action: GroundAction) -> dict[str, str] | None:
        """The objects of the step's variables when ``action`` matches it, else ``None``."""
        if self.name not in (ANY_ACTION, action.name):
            return None
        if self.args is None:
            return {}
        if len(self.args) != len(action.args):
            return None
        binding: dict[str, str] = {}
        for pattern, obj in zip(self.args, action.args, strict=True):
            if pattern is None:
                continue
            if isinstance(pattern, str):
                if binding.setdefault(pattern, obj) != obj:
                    return None
            elif obj not in pattern:
                return None
        return binding

    def variables(self) -> set[str]:
        return {a for a in self.args or () if isinstance(a, str)}

    def __str__(self) -> str:
        def word(pattern: ArgPattern) -> str:
            if pattern is None:
                return ANY_ARG
            if isinstance(pattern, str):
                return pattern
            if len(pattern) == 1:
                return next(iter(pattern))
            return "{" + ",".join(sorted(pattern)) + "}"
        return " ".join((self.name, *(word(a) for a in self.args or ())))


@dataclass(frozen=True)
class Skeleton:
    """Steps, their ``orders`` (pairs of step indices; ``GOAL`` as a target: done at the
    end) and the open ``gaps`` (``len(steps) + 1`` flags, in order for a linear skeleton;
    all equal otherwise)."""

    steps: tuple[StepPattern, ...]
    orders: frozenset[tuple[int, int]]
    gaps: tuple[bool, ...]

    @classmethod
    def linear(cls, steps: Sequence[StepPattern], gaps: Sequence[bool] | bool) -> Skeleton:
        """Steps in sequence, the last one done at the end (PDDLStream's ``linear_order``)."""
        count = len(steps)
        orders = {(i, i + 1) for i in range(count - 1)} | ({(count - 1, GOAL)} if count else set())
        flags = tuple(gaps) if not isinstance(gaps, bool) else (gaps,) * (count + 1)
        return cls(tuple(steps), frozenset(orders), flags)

    def is_linear(self) -> bool:
        return self.orders == Skeleton.linear(self.steps, False).orders

    def predecessors(self, step: int) -> list[int]:
        return sorted(i for i, j in self.orders if j == step)

    def ancestors(self, step: int) -> set[int]:
        found: set[int] = set()
        frontier = self.predecessors(step)
        while frontier:
            i = frontier.pop()
            if i not in found:
                found.add(i)
                frontier.extend(self.predecessors(i))
        return found

    def __str__(self) -> str:
        return " ; ".join(str(step) for step in self.steps)


@dataclass(frozen=True)
class PlanConstraints:
    """The plan must complete one of ``skeletons`` (at least one)."""

    skeletons: tuple[Skeleton, ...]

    def describe(self) -> str:
        return " | ".join(f"[{skeleton}]" for skeleton in self.skeletons)


def parse_skeleton(entries: Sequence[str]) -> Skeleton:
    """A linear skeleton from ``"NAME ARG ..."`` strings (``?`` any argument, ``?x`` a
    variable, ``*`` any one action, ``...`` an open gap); names are lower-cased as PDDL's."""
    steps: list[StepPattern] = []
    gaps = [False]
    for entry in entries:
        words = str(entry).lower().split()
        if not words:
            raise InputError("an empty skeleton entry: expected an action pattern, '*' or '...'")
        if words == [ANY_SEQUENCE]:
            gaps[-1] = True
            continue
        name, args = words[0], words[1:]
        if name == ANY_ACTION or not args:
            if name == ANY_ACTION and args:
                raise InputError(f"skeleton entry {entry!r}: '*' (any action) takes no arguments")
            steps.append(StepPattern(name))
        else:
            steps.append(StepPattern(name, tuple(_arg_pattern(a) for a in args)))
        gaps.append(False)
    return Skeleton.linear(steps, gaps)


def _arg_pattern(word: str) -> ArgPattern:
    if word == ANY_ARG:
        return None
    if word.startswith(ANY_ARG):
        return word
    return frozenset({word})


def parse_constraints(skeletons: Iterable[Sequence[str]]) -> PlanConstraints | None:
    """Constraints from skeletons written as strings (``None`` when there are none; an
    empty skeleton is the empty plan, as in PDDLStream)."""
    parsed = tuple(parse_skeleton(entries) for entries in skeletons)
    return PlanConstraints(parsed) if parsed else None


def check_constraints(constraints: PlanConstraints, arities: dict[str, int]) -> None:
    """Refuse (one line) what cannot be compiled or names no action: a misspelt pattern
    would otherwise only make the problem infeasible."""
    if not constraints.skeletons:
        raise InputError("plan constraints with no skeleton: no plan can follow one "
                         "(give no constraints to plan freely)")
    for number, skeleton in enumerate(constraints.skeletons, start=1):
        count = len(skeleton.steps)
        if len(skeleton.gaps) != count + 1:
            raise InputError(f"skeleton #{number}: {len(skeleton.gaps)} gap flags for "
                             f"{count} steps (expected {count + 1})")
        for before, after in skeleton.orders:
            if not (0 <= before < count and (after == GOAL or 0 <= after < count)):
                raise InputError(f"skeleton #{number}: order ({before}, {after}) names no "
                                 f"step (steps 0..{count - 1}, or {GOAL} for the goal)")
            if before == after or before in skeleton.ancestors(before):
                raise InputError(f"skeleton #{number}: its orders form a cycle through "
                                 f"step {before}")
        if len(set(skeleton.gaps)) > 1 and not skeleton.is_linear():
            raise InputError(f"skeleton #{number}: '...' in some gaps only needs a linear "
                             "skeleton (a partial order allows other actions everywhere or "
                             "nowhere)")
        for step in skeleton.steps:
            if step.name == ANY_ACTION:
                continue
            if step.name not in arities:
                raise InputError(f"skeleton pattern {step.name!r}: the domain has no such "
                                 f"action (actions: {', '.join(sorted(arities))})")
            if step.args is not None and len(step.args) != arities[step.name]:
                raise InputError(f"skeleton pattern {step.name!r} gives {len(step.args)} "
                                 f"argument(s); the action takes {arities[step.name]}")
    mixed = {all(s.gaps) for s in constraints.skeletons} | {any(s.gaps) for s in
                                                           constraints.skeletons}
    if len(constraints.skeletons) > 1 and len(mixed) > 1:
        raise InputError("several skeletons must all allow other actions everywhere ('...' "
                         "in every gap, PDDLStream's exact=False) or nowhere (exact=True)")


def equates_arguments(constraints: PlanConstraints, known: set[str]) -> bool:
    """Whether a skeleton ties an argument to another (a variable named twice) or to an
    object not among ``known`` (one a stream may make): optimistic plans, whose stream
    outputs are distinct placeholders, cannot meet such a tie, so their failure proves no
    infeasibility."""
    for skeleton in constraints.skeletons:
        named: list[str] = []
        for step in skeleton.steps:
            for pattern in step.args or ():
                if isinstance(pattern, str):
                    named.append(pattern)
                elif isinstance(pattern, frozenset) and not pattern <= known:
                    return True
        if len(named) != len(set(named)):
            return True
    return False


def done_fact(skeleton: int, step: int) -> Fact:
    return (DONE, str(skeleton), str(step))


def constrain(grounding: Grounding, constraints: PlanConstraints) -> Grounding:
    """The grounding restricted to plans that complete one of the skeletons (the initial
    state needs no new fact: every skeleton starts with no step done)."""
    free_everywhere = all(all(s.gaps) for s in constraints.skeletons)
    actions: list[GroundAction] = list(grounding.actions) if free_everywhere else []
    new_facts: set[Fact] = set()
    completions: list[GroundAxiom] = []
    for number, skeleton in enumerate(constraints.skeletons):
        for action in grounding.actions:
            for index, step in enumerate(skeleton.steps):
                binding = step.match(action)
                if binding is not None:
                    actions.extend(_step_copies(action, number, skeleton, index, binding,
                                                range(len(constraints.skeletons))))
            if not free_everywhere:
                actions.extend(_gap_copies(action, number, skeleton))
        final = tuple(done_fact(number, i) for i, j in sorted(skeleton.orders) if j == GOAL)
        completions.append(GroundAxiom((COMPLETE,), final, ()))
        new_facts.update(done_fact(number, i) for i in range(len(skeleton.steps)))
        new_facts.add((STARTED, str(number)))
    for action in actions:
        new_facts.update(e.fact for e in action.effects if e.fact[0] in (ASSIGNED, BOUND))
    if any(not axiom.body_pos for axiom in completions):
        axioms = list(grounding.axioms)  # a skeleton with no final step: always complete
    else:
        axioms = [GroundAxiom(a.head, (*a.body_pos, (COMPLETE,)), a.body_neg, a.static_pos)
                  if a.head == (GOAL_PREDICATE,) else a for a in grounding.axioms]
        axioms.extend(completions)
    return replace(grounding, actions=actions, axioms=axioms,
                   derived_predicates=grounding.derived_predicates | {COMPLETE},
                   reachable=grounding.reachable | new_facts | {(COMPLETE,)})


def _step_copies(action: GroundAction, number: int, skeleton: Skeleton, index: int,
                 binding: dict[str, str], others: range) -> Iterator[GroundAction]:
    """``action`` as step ``index`` of skeleton ``number``: one copy, or one per way to
    meet a variable that a step unordered with this one may have bound first."""
    key = str(number)
    ancestors = skeleton.ancestors(index)
    descendants = {i for i in range(len(skeleton.steps)) if index in skeleton.ancestors(i)}
    earlier = {v for i in ancestors for v in skeleton.steps[i].variables()}
    parallel = {v for i in range(len(skeleton.steps)) if i not in ancestors | descendants | {index}
                for v in skeleton.steps[i].variables()}
    pre_pos = [done_fact(number, i) for i in skeleton.predecessors(index)]
    # Steps of one skeleton only: exact, the plan is then one of the skeletons (PDDLStream
    # lets steps of several mix, a gap its own comment marks; "exactly one" is the intent).
    pre_neg = [done_fact(number, index), *((STARTED, str(other)) for other in others
                                           if other != number)]
    adds = [done_fact(number, index), (STARTED, key)]
    choices: list[list[tuple[tuple[Fact, ...], tuple[Fact, ...], tuple[Fact, ...]]]] = []
    for variable, obj in sorted(binding.items()):
        assigned, bound = (ASSIGNED, key, variable, obj), (BOUND, key, variable)
        if variable in earlier:  # an ancestor bound it: the same object
            pre_pos.append(assigned)
        elif variable in parallel:  # either this step binds it first, or it agrees
            choices.append([((), (bound,), (bound, assigned)), ((assigned,), (), ())])
        else:  # the first step to bind it
            adds.extend((bound, assigned))
    for combination in product(*choices):
        extra_pos = [f for option in combination for f in option[0]]
        extra_neg = [f for option in combination for f in option[1]]
        extra_adds = [f for option in combination for f in option[2]]
        effects = (*action.effects,
                   *(GroundEffect((), (), fact, True) for fact in (*adds, *extra_adds)))
        yield replace(action, pre_pos=(*action.pre_pos, *pre_pos, *extra_pos),
                      pre_neg=(*action.pre_neg, *pre_neg, *extra_neg), effects=effects)


def _gap_copies(action: GroundAction, number: int, skeleton: Skeleton) -> Iterator[GroundAction]:
    """``action`` as a free action in each open gap of a linear skeleton: after the step
    before the gap, before the step after it."""
    last = len(skeleton.steps)
    for gap, is_open in enumerate(skeleton.gaps):
        if not is_open:
            continue
        after = (done_fact(number, gap - 1),) if gap > 0 else ()
        before = (done_fact(number, gap),) if gap < last else ()
        yield replace(action, pre_pos=(*action.pre_pos, *after),
                      pre_neg=(*action.pre_neg, *before))
