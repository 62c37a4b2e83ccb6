"""Grounding by relaxed reachability (semi-naive Datalog evaluation).

Starting from the initial facts, rules (action variants, axiom rules) are instantiated
whenever all their positive literals are reachable; their add effects / heads become
reachable in turn, until a fixpoint. Negative literals are ignored for reachability except
on *static* predicates (never changed by an action), which are decided exactly.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field

from ltamp_cli.planner.pddl.syntax import (
    EQUALITY,
    OBJECT_TYPE,
    FunctionTerm,
    Number,
    is_variable,
)
from ltamp_cli.planner.search.clock import NO_DEADLINE, check_deadline, sorted_before
from ltamp_cli.planner.search.normalize import (
    GOAL_PREDICATE,
    Clause,
    LiftedLiteral,
    NormalAction,
    NormalAxiom,
)

Fact = tuple[str, ...]  # (predicate, *args)
# A fluent context: (predicates, facts). It holds in a state whose facts of those predicates
# are exactly the given facts (what a :fluents stream was called with).
Context = tuple[tuple[str, ...], tuple[Fact, ...]]
OBJECT_TYPE_PREDICATE = f"type:{OBJECT_TYPE}"
HEAD_POSITION = -1  # key of a rule's join that starts from its head's arguments


@dataclass(frozen=True)
class GroundEffect:
    condition_pos: tuple[Fact, ...]
    condition_neg: tuple[Fact, ...]
    fact: Fact
    positive: bool
    #: The static facts of the condition, true when the effect was ground and then dropped
    #: from it (as an action's ``static_pre``): a plan whose effect fired relies on them,
    #: and an optimistic one must have them certified (``plan_preimage``).
    static_pos: tuple[Fact, ...] = ()


@dataclass(frozen=True)
class GroundAction:
    name: str
    args: tuple[str, ...]
    pre_pos: tuple[Fact, ...]
    pre_neg: tuple[Fact, ...]
    effects: tuple[GroundEffect, ...]
    cost: float
    static_pre: tuple[Fact, ...] = ()
    cost_terms: tuple[Fact, ...] = ()

    def __str__(self) -> str:
        return "(" + " ".join((self.name, *self.args)) + ")"


@dataclass(frozen=True)
class GroundAxiom:
    head: Fact
    body_pos: tuple[Fact, ...]
    body_neg: tuple[Fact, ...]
    static_pos: tuple[Fact, ...] = ()


@dataclass
class Grounding:
    actions: list[GroundAction]
    axioms: list[GroundAxiom]
    reachable: set[Fact]
    static_predicates: frozenset[str]
    derived_predicates: frozenset[str] = frozenset()
    # Axiom instances discarded because a static negative literal held: (head, the
    # non-static positive body, the blocking static fact). Needed to explain *why* a
    # negated derived fact is false (e.g. which collision-free certificates a plan uses).
    blocked_axioms: list[tuple[Fact, tuple[Fact, ...], Fact]] = field(default_factory=list)


class FactIndex:
    """Facts by predicate, with lazily built indexes on bound argument positions."""

    def __init__(self) -> None:
        self.by_predicate: dict[str, list[tuple[str, ...]]] = defaultdict(list)
        self.members: set[Fact] = set()
        self._indexes: dict[tuple[str, tuple[int, ...]], dict[tuple[str, ...], list]] = {}
        self._indexes_by_predicate: dict[str, list[tuple[int, ...]]] = defaultdict(list)

    @classmethod
    def of_sorted(cls, facts: Sequence[Fact], deadline: float = NO_DEADLINE,
                  chunk: int = 8192) -> FactIndex:
        """An index of ``facts`` (sorted, no duplicates), as adding them one by one would
        make it (no argument index exists yet, so none is updated): a bulk load, since
        every grounding and optimistic evaluation starts with thousands of facts. Loaded
        ``chunk`` facts at a time with a deadline check between (``set.update`` of 10^5
        facts is one C call)."""
        index = cls()
        members = index.members
        by_predicate = index.by_predicate
        for begin in range(0, len(facts), chunk):
            check_deadline(deadline)
            part = facts[begin:begin + chunk]
            members.update(part)
            for fact in part:
                by_predicate[fact[0]].append(fact[1:])
        return index

    def add(self, fact: Fact) -> bool:
        if fact in self.members:
            return False
        self.members.add(fact)
        predicate, args = fact[0], fact[1:]
        self.by_predicate[predicate].append(args)
        for positions in self._indexes_by_predicate[predicate]:
            key = tuple(args[i] for i in positions)
            self._indexes[(predicate, positions)].setdefault(key, []).append(args)
        return True

    def lookup(self, predicate: str, positions: tuple[int, ...], key: tuple[str, ...]
               ) -> Sequence[tuple[str, ...]]:
        if not positions:
            return self.by_predicate.get(predicate, ())
        index = self._indexes.get((predicate, positions))
        if index is None:
            index = {}
            for args in self.by_predicate.get(predicate, ()):
                index.setdefault(tuple(args[i] for i in positions), []).append(args)
            self._indexes[(predicate, positions)] = index
            self._indexes_by_predicate[predicate].append(positions)
        return index.get(key, ())

    def in_discovery_order(self) -> list[Fact]:
        """Every fact, by predicate (first seen first) and within a predicate in the order
        added: deterministic for a deterministic solve, and linear where sorting is not."""
        return [(predicate, *args) for predicate, rows in self.by_predicate.items()
                for args in rows]

    def sizes(self) -> dict[str, int]:
        """Facts per predicate so far: facts are only ever appended, so this marks a point
        after which :func:`join_new` finds what was added."""
        return {predicate: len(args) for predicate, args in self.by_predicate.items()}


@dataclass(frozen=True)
class _Step:
    """Match one literal: ``bound`` positions are looked up, ``binds`` set new variables."""

    predicate: str
    positions: tuple[int, ...]
    key_terms: tuple[str, ...]  # variable names or constants at bound positions
    binds: tuple[tuple[int, str], ...]
    checks: tuple[tuple[int, int], ...]  # repeated new variable within the literal


def _compile_join(literals: Sequence[LiftedLiteral], bound: set[str],
                  index: FactIndex | None = None) -> list[_Step]:
    """Order literals greedily (most bound first; among equally bound ones, the predicate
    with the fewest facts in ``index``) and precompute lookups."""
    remaining = list(literals)
    bound = set(bound)
    steps = []
    sizes = index.by_predicate if index is not None else {}
    while remaining:
        def score(lit: LiftedLiteral) -> tuple[int, int, int]:
            known = sum(1 for a in lit.args if not is_variable(a) or a in bound)
            return (-(known == len(lit.args)), -known, len(sizes.get(lit.predicate, ())))

        literal = min(remaining, key=score)
        remaining.remove(literal)
        positions, key_terms, binds, checks = [], [], [], []
        first_seen: dict[str, int] = {}
        for i, arg in enumerate(literal.args):
            if not is_variable(arg) or arg in bound:
                positions.append(i)
                key_terms.append(arg)
            elif arg in first_seen:
                checks.append((first_seen[arg], i))
            else:
                first_seen[arg] = i
                binds.append((i, arg))
        bound.update(first_seen)
        steps.append(_Step(literal.predicate, tuple(positions), tuple(key_terms), tuple(binds),
                           tuple(checks)))
    return steps


def _run_join(steps: Sequence[_Step], index: FactIndex, binding: dict[str, str]
              ) -> list[dict[str, str]]:
    """Every extension of ``binding`` matching ``steps``, collected eagerly (facts that the
    caller adds while using them are found by its own semi-naive rounds)."""
    found: list[dict[str, str]] = []
    _extend(steps, 0, index, binding, found)
    return found


def _extend(steps: Sequence[_Step], depth: int, index: FactIndex, binding: dict[str, str],
            found: list, project: tuple[str, ...] | None = None) -> None:
    """Append the extensions of ``binding`` by ``steps[depth:]`` to ``found``: as dicts, or
    with ``project`` as tuples of those variables' values (no dict per result)."""
    if depth == len(steps):
        found.append(binding if project is None else tuple([binding[v] for v in project]))
        return
    step = steps[depth]
    key = tuple([binding.get(term, term) for term in step.key_terms])
    last = depth + 1 == len(steps)
    checks, binds = step.checks, step.binds
    if last and project is not None:
        here = {variable: position for position, variable in binds}
        plan = [(here.get(v, -1), v) for v in project]
        for args in index.lookup(step.predicate, step.positions, key):
            if checks and any(args[a] != args[b] for a, b in checks):
                continue
            found.append(tuple([args[p] if p >= 0 else binding[v] for p, v in plan]))
        return
    for args in index.lookup(step.predicate, step.positions, key):
        if checks and any(args[a] != args[b] for a, b in checks):
            continue
        extended = binding.copy()
        for position, variable in binds:
            extended[variable] = args[position]
        if last:
            found.append(extended)
        else:
            _extend(steps, depth + 1, index, extended, found, project)


def join(literals: Sequence[LiftedLiteral], index: FactIndex,
         binding: Mapping[str, str] | None = None) -> Iterator[dict[str, str]]:
    """All bindings of the literals' variables such that every literal is in ``index``."""
    start = dict(binding or {})
    yield from _run_join(_compile_join(literals, set(start)), index, start)


def join_new(literals: Sequence[LiftedLiteral], index: FactIndex, since: Mapping[str, int]
             ) -> Iterator[dict[str, str]]:
    """Bindings of ``literals`` in ``index`` that use at least one fact added after ``since``
    (a :meth:`FactIndex.sizes` snapshot): semi-naive evaluation, so a fixpoint loop does not
    redo every earlier join. A binding using several new facts may be yielded more than once.
    """
    for steps, binding in _new_fact_seeds(literals, index, since):
        yield from _run_join(steps, index, binding)


def _new_fact_seeds(literals: Sequence[LiftedLiteral], index: FactIndex,
                    since: Mapping[str, int]) -> Iterator[tuple[list[_Step], dict[str, str]]]:
    """For each fact added after ``since`` that matches one of ``literals``: the join of the
    other literals and the binding that fact gives (the seeds of a semi-naive round)."""
    for position, literal in enumerate(literals):
        facts = index.by_predicate.get(literal.predicate, ())
        start = since.get(literal.predicate, 0)
        if start >= len(facts):
            continue
        others = [lit for i, lit in enumerate(literals) if i != position]
        steps: list[_Step] | None = None
        for args in facts[start:]:
            binding = _match(literal, args)
            if binding is None:
                continue
            if steps is None:
                steps = _compile_join(others, set(binding))
            yield steps, binding


@dataclass
class CostBound:
    """Keep only the bindings whose projected variables' values cost at most ``budget`` in
    total (``cost`` per value, 0 when absent, never negative); a partial binding over it is
    not extended. ``exceeded`` is set once a complete binding over the budget is known to
    exist (checked for the first pruned partial binding that has one). ``highest``: the
    most costly value counts instead of the total."""

    cost: Mapping[str, int]
    budget: int
    exceeded: bool = False
    highest: bool = False


def join_tuples(literals: Sequence[LiftedLiteral], index: FactIndex,
                variables: tuple[str, ...], since: Mapping[str, int] | None = None,
                bound: CostBound | None = None) -> list[tuple[str, ...]]:
    """:func:`join` (or, with ``since``, :func:`join_new`) with each binding given as the
    tuple of ``variables``' values; with ``since`` and ``bound``, only those within the
    bound (the others, in the same order, are left out)."""
    found: list[tuple[str, ...]] = []
    if since is None:
        _extend(_compile_join(literals, set()), 0, index, {}, found, variables)
        return found
    weighted = frozenset(variables)
    for steps, binding in _new_fact_seeds(literals, index, since):
        if bound is None:
            _extend(steps, 0, index, binding, found, variables)
            continue
        costs = [bound.cost.get(value, 0) for variable, value in binding.items()
                 if variable in weighted]
        spent = max(costs, default=0) if bound.highest else sum(costs)
        if spent <= bound.budget:
            _extend_bounded(steps, 0, index, binding, found, variables, bound, weighted, spent)
        elif not bound.exceeded:
            complete: list[tuple[str, ...]] = []
            _extend(steps, 0, index, binding, complete, variables)
            bound.exceeded = bool(complete)
    return found


def _extend_bounded(steps: Sequence[_Step], depth: int, index: FactIndex,
                    binding: dict[str, str], found: list[tuple[str, ...]],
                    project: tuple[str, ...], bound: CostBound, weighted: frozenset[str],
                    spent: int) -> None:
    """:func:`_extend` (projecting) that prunes bindings whose values of ``weighted``
    variables cost more than the bound; costs are non-negative, so a pruned partial binding
    has no extension within it."""
    if depth == len(steps):
        found.append(tuple([binding[v] for v in project]))
        return
    step = steps[depth]
    key = tuple([binding.get(term, term) for term in step.key_terms])
    checks, binds = step.checks, step.binds
    costed = [position for position, variable in binds if variable in weighted]
    cost, budget = bound.cost, bound.budget
    last = depth + 1 == len(steps)
    for args in index.lookup(step.predicate, step.positions, key):
        if checks and any(args[a] != args[b] for a, b in checks):
            continue
        total = spent
        for position in costed:
            if bound.highest:
                total = max(total, cost.get(args[position], 0))
            else:
                total += cost.get(args[position], 0)
        if total > budget and bound.exceeded:
            continue
        extended = binding.copy()
        for position, variable in binds:
            extended[variable] = args[position]
        if total > budget:
            # The first pruned partial bindings are completed once, unbounded, until one
            # shows that a binding over the budget exists.
            complete: list[tuple[str, ...]] = []
            _extend(steps, depth + 1, index, extended, complete, project)
            bound.exceeded = bool(complete)
            continue
        if last:
            found.append(tuple([extended[v] for v in project]))
        else:
            _extend_bounded(steps, depth + 1, index, extended, found, project, bound,
                            weighted, total)


def _ground(args: Iterable[str], binding: Mapping[str, str]) -> tuple[str, ...]:
    return tuple([binding.get(a, a) for a in args])


def _match(literal: LiftedLiteral, args: tuple[str, ...]) -> dict[str, str] | None:
    binding: dict[str, str] = {}
    for term, value in zip(literal.args, args, strict=True):
        if is_variable(term):
            if binding.setdefault(term, value) != value:
                return None
        elif term != value:
            return None
    return binding


@dataclass
class _Rule:
    source: NormalAction | NormalAxiom
    positive: tuple[LiftedLiteral, ...]
    negative: tuple[LiftedLiteral, ...]
    equalities: tuple[LiftedLiteral, ...]
    variables: tuple[str, ...]
    joins: dict[int, list[_Step]] = field(default_factory=dict)
    compiled: _Compiled | None = None  # set by the first _emit of a grounding


def _make_rule(source: NormalAction | NormalAxiom, clause: Clause) -> _Rule:
    positive = _without_redundant_object_types(
        [lit for lit in clause if lit.positive and lit.predicate != EQUALITY])
    negative = tuple(lit for lit in clause if not lit.positive and lit.predicate != EQUALITY)
    equalities = tuple(lit for lit in clause if lit.predicate == EQUALITY)
    variables = tuple(sorted({a for lit in clause for a in lit.args if is_variable(a)}))
    return _Rule(source, positive, negative, equalities, variables)


def _without_redundant_object_types(literals: list[LiftedLiteral]) -> tuple[LiftedLiteral, ...]:
    """Drop ``type:object(?x)`` when ``?x`` occurs in another positive literal: every name in
    a fact is an object, so the literal only multiplies join work."""
    bound_elsewhere = {
        arg for lit in literals if lit.predicate != OBJECT_TYPE_PREDICATE for arg in lit.args}
    return tuple(
        lit for lit in literals
        if not (lit.predicate == OBJECT_TYPE_PREDICATE and lit.args[0] in bound_elsewhere))


def static_predicates(actions: Sequence[NormalAction], derived: Iterable[str]) -> frozenset[str]:
    changed = {e.predicate for action in actions for e in action.effects}
    return frozenset(changed | set(derived))


def ground_task(
    actions: Sequence[NormalAction],
    axioms: Sequence[NormalAxiom],
    init: Iterable[Fact],
    function_values: Mapping[Fact, float],
    deadline: float = NO_DEADLINE,
) -> Grounding:
    """Instantiate every reachable action and axiom rule (:class:`.SearchTimeout` once
    ``time.perf_counter()`` passes ``deadline``)."""
    derived = {axiom.predicate for axiom in axioms}
    fluent = static_predicates(actions, derived)  # predicates that are *not* static
    init_facts = set(init)
    # Sorted: string hashing varies between processes, and order decides tie-breaking later.
    # In bounded steps (the initial facts of an optimistic task can number 10^5: one
    # ``sorted`` call of them held the GIL for seconds past the deadline under load).
    index = FactIndex.of_sorted(sorted_before(init_facts, deadline), deadline)
    rule_set = RuleSet(actions, axioms)

    seen: set[tuple[int, tuple[str, ...]]] = set()
    result = Grounding([], [], index.members, frozenset(), frozenset(derived))

    def emit(rule: _Rule, binding: dict[str, str], delta: list[Fact]) -> None:
        _emit(rule, binding, index, init_facts, fluent, function_values, seen, result, delta)

    semi_naive_fixpoint(rule_set, index, None, emit, deadline)
    _ground_on_demand(rule_set.demanded, index, init_facts, fluent, function_values, seen,
                      result, deadline)
    result.static_predicates = frozenset(
        {fact[0] for fact in index.members} - fluent
    )
    # A canonical order (the search breaks ties by operator index): plans then do not
    # depend on the order in which the joins happened to find the instances.
    result.actions = sorted_before(
        result.actions, deadline,
        key=lambda a: (a.name, a.args, a.pre_pos, a.pre_neg, a.static_pre))
    result.axioms = sorted_before(
        result.axioms, deadline, key=lambda a: (a.head, a.body_pos, a.body_neg, a.static_pos))
    return result


class RuleSet:
    """A grounding's rules: ``rules``, grounded by reachability, and ``demanded`` (the
    rules of negative-only derived predicates, by predicate, see
    :func:`_negative_only_predicates`), with ``by_predicate``: each main rule's positive
    literals by predicate, as (rule, literal position) pairs."""

    def __init__(self, actions: Sequence[NormalAction], axioms: Sequence[NormalAxiom]
                 ) -> None:
        rules = [_make_rule(a, a.precondition) for a in actions]
        rules += [_make_rule(a, a.body) for a in axioms]
        self.on_demand = _negative_only_predicates(actions, axioms)
        self.demanded: dict[str, list[_Rule]] = defaultdict(list)
        self.rules: list[_Rule] = []
        for rule in rules:
            source = rule.source
            if isinstance(source, NormalAxiom) and source.predicate in self.on_demand:
                self.demanded[source.predicate].append(rule)
            else:
                self.rules.append(rule)
        self.by_predicate: dict[str, list[tuple[_Rule, int]]] = defaultdict(list)
        for rule in self.rules:
            for position, literal in enumerate(rule.positive):
                self.by_predicate[literal.predicate].append((rule, position))


# ``emit(rule, binding, delta)``: record the instance of ``rule`` for ``binding`` and append
# the facts it makes reachable for the first time to ``delta``.
Emit = Callable[[_Rule, dict[str, str], list[Fact]], object]


def semi_naive_fixpoint(rule_set: RuleSet, index: FactIndex, delta: list[Fact] | None,
                        emit: Emit, deadline: float, stride: int = 1) -> None:
    """Semi-naive evaluation of ``rule_set``'s main rules over ``index``, instances handed
    to ``emit``. ``delta=None``: from scratch, one full join per rule over the facts in
    ``index`` (a rule instance over them is found once, not once per positive literal);
    else ``delta`` holds facts just added to ``index``, whose consequences are joined.
    Then, until no new fact comes, only the joins that use a new fact run (the rule's
    other literals joined from the new fact's binding, compiled once per rule and
    position). The deadline is checked every ``stride`` new facts."""
    if delta is None:
        delta = []
        for rule in rule_set.rules:
            check_deadline(deadline)
            if not rule.positive:  # e.g. a parameterless action with an empty precondition
                emit(rule, {}, delta)
                continue
            for binding in _run_join(_compile_join(rule.positive, set(), index), index, {}):
                emit(rule, binding, delta)
    while delta:
        current, delta = delta, []
        for number, fact in enumerate(current):
            if number % stride == 0:
                check_deadline(deadline)
            for rule, position in rule_set.by_predicate.get(fact[0], ()):
                start = _match(rule.positive[position], fact[1:])
                if start is None:
                    continue
                steps = rule.joins.get(position)
                if steps is None:
                    others = [lit for i, lit in enumerate(rule.positive) if i != position]
                    steps = _compile_join(others, set(start), index)
                    rule.joins[position] = steps
                for binding in _run_join(steps, index, start):
                    emit(rule, binding, delta)


def head_bindings(rule: _Rule, fact: Fact, index: FactIndex) -> Iterator[dict[str, str]]:
    """The bindings of a derived ``rule`` whose head is ``fact`` and whose positive body
    holds in ``index`` (the join from the head's arguments, compiled once per rule)."""
    head = LiftedLiteral(fact[0], rule.source.head_args)  # type: ignore[union-attr]
    binding = _match(head, fact[1:])
    if binding is None:
        return
    steps = rule.joins.get(HEAD_POSITION)
    if steps is None:
        steps = _compile_join(rule.positive, set(binding), index)
        rule.joins[HEAD_POSITION] = steps
    yield from _run_join(steps, index, binding)


def _negative_only_predicates(actions: Sequence[NormalAction], axioms: Sequence[NormalAxiom]
                              ) -> frozenset[str]:
    """Derived predicates that no rule body, effect condition or goal uses positively.

    Reachability never depends on them (negative literals do not constrain it), so their
    axioms are grounded last and only for the instances that grounded rules negate: the
    ``not aux(?b ?p)`` of a ``forall`` precondition then costs one axiom instance per
    grounded action instead of one per pair of objects (thousands of optimistic objects
    in TAMP). The search never reads the other instances.
    """
    derived = {axiom.predicate for axiom in axioms} - {GOAL_PREDICATE}
    used_positively = {lit.predicate for axiom in axioms for lit in axiom.body if lit.positive}
    for action in actions:
        used_positively.update(lit.predicate for lit in action.precondition if lit.positive)
        used_positively.update(lit.predicate for effect in action.effects
                               for lit in effect.condition if lit.positive)
    return frozenset(derived - used_positively)


def _negated_facts(result: Grounding, start: tuple[int, int], predicates: frozenset[str]
                   ) -> Iterator[Fact]:
    """Negated facts of ``predicates`` in the actions and axioms grounded since ``start``
    (counts of actions, axioms)."""
    for action in result.actions[start[0]:]:
        yield from (fact for fact in action.pre_neg if fact[0] in predicates)
        for effect in action.effects:
            yield from (fact for fact in effect.condition_neg if fact[0] in predicates)
    for axiom in result.axioms[start[1]:]:
        yield from (fact for fact in axiom.body_neg if fact[0] in predicates)


def _ground_on_demand(demanded: Mapping[str, list[_Rule]], index: FactIndex, init: set[Fact],
                      fluent: frozenset[str], function_values: Mapping[Fact, float],
                      seen: set[tuple[int, tuple[str, ...]]], result: Grounding,
                      deadline: float) -> None:
    """Ground the rules of negative-only derived predicates for the heads that grounded
    rules negate, until no new head is needed (their own bodies may negate others)."""
    if not demanded:
        return
    predicates = frozenset(demanded)
    done: set[Fact] = set()
    start = (0, 0)
    while True:
        needed = [fact for fact in dict.fromkeys(_negated_facts(result, start, predicates))
                  if fact not in done]
        start = (len(result.actions), len(result.axioms))
        if not needed:
            return
        for fact in needed:
            done.add(fact)
            check_deadline(deadline)
            for rule in demanded[fact[0]]:
                for extended in head_bindings(rule, fact, index):
                    _emit(rule, extended, index, init, fluent, function_values, seen, result,
                          [])


@dataclass
class _Compiled:
    """A rule's literals split once per grounding by whether their predicate is fluent."""

    dynamic_pos: tuple[tuple[str, tuple[str, ...]], ...]
    static_pos: tuple[tuple[str, tuple[str, ...]], ...]  # without type literals
    dynamic_neg: tuple[tuple[str, tuple[str, ...]], ...]
    static_neg: tuple[tuple[str, tuple[str, ...]], ...]


def _compile_rule(rule: _Rule, fluent: frozenset[str]) -> _Compiled:
    def split(literals: Iterable[LiftedLiteral], dynamic: bool
              ) -> tuple[tuple[str, tuple[str, ...]], ...]:
        return tuple((lit.predicate, lit.args) for lit in literals
                     if (lit.predicate in fluent) == dynamic
                     and (dynamic or not lit.predicate.startswith("type:")))

    return _Compiled(split(rule.positive, True), split(rule.positive, False),
                     split(rule.negative, True),
                     tuple((lit.predicate, lit.args) for lit in rule.negative
                           if lit.predicate not in fluent))


def _emit(rule: _Rule, binding: dict[str, str], index: FactIndex, init: set[Fact],
          fluent: frozenset[str], function_values: Mapping[Fact, float],
          seen: set[tuple[int, tuple[str, ...]]], result: Grounding, delta: list[Fact]
          ) -> None:
    key = (id(rule), tuple([binding[v] for v in rule.variables]))
    if key in seen:
        return
    seen.add(key)
    get = binding.get
    for literal in rule.equalities:
        left, right = _ground(literal.args, binding)
        if (left == right) != literal.positive:
            return
    compiled = rule.compiled
    if compiled is None:
        compiled = rule.compiled = _compile_rule(rule, fluent)
    blocking: Fact | None = None
    for predicate, terms in compiled.static_neg:
        fact = (predicate, *[get(a, a) for a in terms])
        if fact in init:
            blocking = fact
            break
    dynamic_pos = tuple([(predicate, *[get(a, a) for a in terms])
                         for predicate, terms in compiled.dynamic_pos])
    source = rule.source
    if blocking is not None:
        if isinstance(source, NormalAxiom):
            head = (source.predicate, *_ground(source.head_args, binding))
            result.blocked_axioms.append((head, dynamic_pos, blocking))
        return
    negative = tuple([(predicate, *[get(a, a) for a in terms])
                      for predicate, terms in compiled.dynamic_neg])
    static_pos = tuple([(predicate, *[get(a, a) for a in terms])
                        for predicate, terms in compiled.static_pos])
    if isinstance(source, NormalAxiom):
        head = (source.predicate, *_ground(source.head_args, binding))
        result.axioms.append(GroundAxiom(head, dynamic_pos, negative, static_pos))
        if index.add(head):
            delta.append(head)
        return
    cost, cost_terms = 0.0, []
    for amount in source.costs:
        if isinstance(amount, Number):
            cost += amount.value
        elif isinstance(amount, FunctionTerm):
            cost_term = (amount.name, *_ground(amount.args, binding))
            if cost_term not in function_values:
                return  # undefined cost: the action is not applicable (as in PDDLStream)
            cost += function_values[cost_term]
            cost_terms.append(cost_term)
    effects = []
    for effect in source.effects:
        cond_pos, cond_neg, cond_static, possible = [], [], [], True
        for literal in effect.condition:
            if literal.predicate == EQUALITY:
                left, right = _ground(literal.args, binding)
                possible &= (left == right) == literal.positive
                continue
            fact = (literal.predicate, *_ground(literal.args, binding))
            if literal.predicate in fluent:
                (cond_pos if literal.positive else cond_neg).append(fact)
            else:
                possible &= (fact in init) == literal.positive
                if literal.positive and not literal.predicate.startswith("type:"):
                    cond_static.append(fact)
        if not possible:
            continue
        fact = (effect.predicate, *[get(a, a) for a in effect.args])
        effects.append(GroundEffect(tuple(cond_pos), tuple(cond_neg), fact, effect.positive,
                                    tuple(cond_static)))
        if effect.positive and index.add(fact):
            delta.append(fact)
    args = tuple([binding[p] for p in source.parameters])
    result.actions.append(GroundAction(source.name, args, dynamic_pos, negative,
                                       tuple(effects), cost, static_pos,
                                       tuple(cost_terms)))


class _ContextLiterals:
    """(facts that must hold, facts that must not) for a context to hold in a grounding,
    with the reachable facts of each predicate set sorted once (a context names a few
    predicates; scanning every reachable fact per context cost PDDLStream's kitchen 1 s)."""

    def __init__(self, grounding: Grounding, deadline: float = NO_DEADLINE) -> None:
        self._by_predicates: dict[tuple[str, ...], tuple[Fact, ...]] = {}
        self._reachable = grounding.reachable
        self._deadline = deadline

    def __call__(self, context: Context) -> tuple[tuple[Fact, ...], tuple[Fact, ...]]:
        predicates, facts = context
        candidates = self._by_predicates.get(predicates)
        if candidates is None:
            wanted = set(predicates)
            candidates = tuple(sorted_before(
                [f for f in self._reachable if f[0] in wanted], self._deadline))
            self._by_predicates[predicates] = candidates
        present = set(facts)
        return tuple(facts), tuple(f for f in candidates if f not in present)


def require_fluent_contexts(grounding: Grounding,
                            requirements: Mapping[Fact, Sequence[Context]],
                            deadline: float = NO_DEADLINE) -> Grounding:
    """Make actions that rely on a fluent stream's fact also require the context it was
    computed under (one copy of the action per alternative context)."""
    import itertools
    from dataclasses import replace

    context_literals = _ContextLiterals(grounding, deadline)
    actions: list[GroundAction] = []
    for action in grounding.actions:
        needs = [requirements[f] for f in action.static_pre if f in requirements]
        if not needs:
            actions.append(action)
            continue
        for choice in itertools.product(*needs):
            check_deadline(deadline)
            positive: list[Fact] = []
            negative: list[Fact] = []
            for context in choice:
                present, absent = context_literals(context)
                positive.extend(present)
                negative.extend(absent)
            actions.append(replace(action,
                                   pre_pos=(*action.pre_pos, *dict.fromkeys(positive)),
                                   pre_neg=(*action.pre_neg, *dict.fromkeys(negative))))
    return replace(grounding, actions=actions)


def forbid_contexts(grounding: Grounding,
                    blocks: Mapping[Fact, Sequence[Context]],
                    deadline: float = NO_DEADLINE) -> Grounding:
    """Actions relying on an optimistic fact of a ``:fluents`` stream may not be applied in a
    state where a context it already failed in holds again: each failed context becomes a
    derived fact (``%failed-context``) that such actions require to be false."""
    from dataclasses import replace

    context_ids: dict[Context, Fact] = {}
    context_literals = _ContextLiterals(grounding, deadline)
    axioms = list(grounding.axioms)
    actions: list[GroundAction] = []
    for action in grounding.actions:
        check_deadline(deadline)
        forbidden: list[Fact] = []
        for fact in action.static_pre:
            for context in blocks.get(fact, ()):
                head = context_ids.get(context)
                if head is None:
                    head = ("%failed-context", str(len(context_ids)))
                    context_ids[context] = head
                    present, absent = context_literals(context)
                    axioms.append(GroundAxiom(head, present, absent))
                forbidden.append(head)
        actions.append(replace(action, pre_neg=(*action.pre_neg, *forbidden))
                       if forbidden else action)
    derived = grounding.derived_predicates | ({"%failed-context"} if context_ids else set())
    return replace(grounding, actions=actions, axioms=axioms,
                   derived_predicates=frozenset(derived),
                   reachable=grounding.reachable | set(context_ids.values()))
