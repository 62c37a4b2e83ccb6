"""Grounding across the searches of one solve, without redoing the joins.

The searches of a solve ground the same normalised rules (actions, axioms) over initial
states that differ in a few hundred of ~2,500 facts: optimistic placeholders come and go
as the optimistic evaluation changes, real values are added. Grounding each from scratch
(:func:`.ground_task`) redoes every join. :class:`GroundingCache` instead keeps one
*union grounding*: the rule instances reachable from the union ``U`` of every initial state
seen so far (extended semi-naively when a state brings new facts), with the parts that
depend on the state left open: the static negative literals that block an instance, the
static conditions of effects, and the action cost looked up in the function values. A
search's grounding is then the subset of those instances reachable from its own initial
state ``I``: a relaxed-reachability fixpoint over ground instances (flat numpy arrays, a
few passes of ``reduceat``), no joins.

Why this equals :func:`.ground_task` over ``I``: reachability is monotone in the initial
facts and every literal that could prune an instance is left open in ``U``, so every
instance that grounding ``I`` finds is one of ``U``'s; the fixpoint then applies exactly
the conditions :func:`.ground_task` applies (positive literals reachable, no static
negative literal in ``I``, equalities, a defined cost; an effect adds its fact when its
static conditions hold in ``I``), and negative-only derived predicates are instantiated for
the heads that included instances negate, as :func:`.ground_task` does. The actions and
axioms come out in the same canonical order, so searches see the same task
(``tests/planner/test_incremental_grounding.py`` compares both on whole solves).

The first task of a rule set is grounded from scratch (a union costs ~1.7x that to build;
a solve with one search gains nothing from it), the union is built on the second. The
union only grows; when it holds more than :data:`RESET_FACTOR` times the instances a
search needs (placeholders that never come back), the next call starts a new union from
that call's state, so a call costs at most a constant factor more than grounding its own
state. It pays when the searches reuse most of what they ground (kitchen_fluent), not when
each brings mostly new instances (tamp2d with uniform placements: slower, also through the
garbage collector's work on the union): hence ``PlannerConfig.incremental_grounding``, off
by default. The cache is keyed by the normalised rules: a domain whose quantifiers are expanded
over changing objects gets a new union whenever its rules change.
"""

from __future__ import annotations

import bisect
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ltamp_cli.planner.pddl.syntax import EQUALITY, FunctionTerm, Number
from ltamp_cli.planner.search.clock import check_deadline, sorted_before
from ltamp_cli.planner.search.ground import (
    Fact,
    FactIndex,
    GroundAction,
    GroundAxiom,
    GroundEffect,
    Grounding,
    RuleSet,
    _compile_rule,
    _ground,
    _new_fact_seeds,
    _Rule,
    _run_join,
    ground_task,
    head_bindings,
    semi_naive_fixpoint,
    static_predicates,
)
from ltamp_cli.planner.search.normalize import NormalAction, NormalAxiom

# A new union is started when the union has more than this many times the instances the
# last call included (plus RESET_SLACK).
RESET_FACTOR = 4
RESET_SLACK = 2000
# Instances handled between two deadline checks.
DEADLINE_STRIDE = 512
FALSE_ID, TRUE_ID = 0, 1  # fact ids of the padding sentinels: never / always in the state


@dataclass(slots=True)
class _Effect:
    """One effect of an action instance, its static conditions left open."""

    effect: GroundEffect  # with its fluent conditions
    static_pos: tuple[int, ...]  # fact ids that must be in the initial state
    static_neg: tuple[int, ...]  # fact ids that must not
    demands: tuple[Fact, ...]  # negated facts of negative-only derived predicates


@dataclass(slots=True)
class _Instance:
    """A rule instance of the union grounding, with what its inclusion depends on."""

    rule: _Rule
    args: tuple[str, ...]  # action parameters' values (empty for axioms)
    positive: tuple[int, ...]  # fact ids of every positive literal
    static_neg: tuple[Fact, ...]  # in the rule's order: the first one in the state blocks
    static_neg_ids: tuple[int, ...]
    dynamic_pos: tuple[Fact, ...]
    dynamic_neg: tuple[Fact, ...]
    static_pos: tuple[Fact, ...]
    head: Fact | None = None  # axioms
    effects: tuple[_Effect, ...] = ()
    # The action's cost amounts in order (numbers, or function terms looked up per task and
    # summed in this order, as ground_task sums them); ``cost``: their sum when all are
    # numbers, else None.
    cost_parts: tuple[float | Fact, ...] = ()
    cost_terms: tuple[Fact, ...] = ()
    cost: float | None = None
    on_demand: bool = False
    demands: tuple[Fact, ...] = ()  # negated facts of negative-only derived predicates
    # ``demands`` and those of every effect (what the union grounds on demand).
    all_demands: tuple[Fact, ...] = ()
    # Ground actions/axioms made of it so far, by (effect flags, cost); ``None`` until one
    # is (a dict per instance would double the objects the garbage collector traverses).
    built: dict[tuple[object, ...], GroundAction | GroundAxiom] | None = None
    # An action with a constant cost and no effect with static conditions or demands: its
    # one ground action (built on first use).
    plain: bool = False
    number: int = -1  # position in the union's flat arrays

    def sort_key(self) -> tuple[object, ...]:
        """:func:`.ground_task`'s canonical order (axioms after actions, never compared)."""
        if self.head is not None:
            return (1, self.head, self.dynamic_pos, self.dynamic_neg, self.static_pos)
        return (0, self.rule.source.name, self.args,  # type: ignore[union-attr]
                self.dynamic_pos, self.dynamic_neg, self.static_pos)


class _Union:
    """The union grounding of one rule set (see the module docstring)."""

    def __init__(self, actions: Sequence[NormalAction], axioms: Sequence[NormalAxiom]) -> None:
        derived = {axiom.predicate for axiom in axioms}
        self.derived = frozenset(derived)
        self.fluent = static_predicates(actions, derived)
        self.index = FactIndex()
        self.facts: list[Fact] = [("%never",), ("%always",)]
        self.fact_ids: dict[Fact, int] = {}
        self.rule_set = RuleSet(actions, axioms)
        self.on_demand_predicates = self.rule_set.on_demand
        self.demanded_rules = self.rule_set.demanded
        self.seen: set[tuple[int, tuple[str, ...]]] = set()
        self.layouts: dict[int, tuple[tuple[tuple[str, tuple[str, ...]], ...],
                                      tuple[int, ...], tuple[int, ...]]] = {}
        self.instances: list[_Instance] = []
        self.demand_instances: dict[Fact, list[_Instance]] = defaultdict(list)
        self.demanded_done: set[Fact] = set()
        self.started = False
        self.arrays_for = -1  # number of main instances the flat arrays describe
        self.demand_scan = 0  # instances whose demands the union has grounded
        self.main: list[_Instance] = []
        # Flat lists behind the arrays of :meth:`_arrays`: preconditions (fact ids, starts),
        # static negative literals (ids, starts), effect rows (owner, fact, positive, static
        # positive conditions and starts, static negative conditions and starts).
        self.lists: list[list[int]] = [[] for _ in range(11)]
        self.row_bounds: list[int] = []  # first effect row of each main instance
        self.row_bounds_end: list[int] = [0]
        self.cost_terms: list[tuple[int, _Instance]] = []  # instances with function terms
        self.on_demand_list: list[bool] = []
        # (sort key, number) of every instance, kept sorted as the union grows.
        self.ranked: list[tuple[tuple[object, ...], int]] = []

    # ----------------------------------------------------------------- union growth

    def fact_id(self, fact: Fact) -> int:
        index = self.fact_ids.get(fact)
        if index is None:
            index = len(self.facts)
            self.fact_ids[fact] = index
            self.facts.append(fact)
        return index

    def extend(self, init: Iterable[Fact], deadline: float) -> None:
        """Add the facts of ``init`` that are new to the union and ground what they reach."""
        members = self.index.members
        delta = sorted_before([fact for fact in init if fact not in members], deadline)
        since = self.index.sizes() if self.started else None
        for fact in delta:
            self.index.add(fact)
        first = not self.started
        self.started = True
        semi_naive_fixpoint(self.rule_set, self.index, None if first else delta, self._emit,
                            deadline, DEADLINE_STRIDE)
        if since is not None:
            self._extend_demanded(since, deadline)
        self._ground_demanded(deadline)

    def _extend_demanded(self, since: Mapping[str, int], deadline: float) -> None:
        """Instances of negative-only derived predicates, for heads already demanded, that
        use a fact added to the union after ``since`` (semi-naive)."""
        for predicate, rules in self.demanded_rules.items():
            for rule in rules:
                check_deadline(deadline)
                head_args = rule.source.head_args  # type: ignore[union-attr]
                for steps, start in _new_fact_seeds(rule.positive, self.index, since):
                    for binding in _run_join(steps, self.index, start):
                        head = (predicate, *_ground(head_args, binding))
                        if head in self.demanded_done:
                            self._emit(rule, binding, None)

    def _ground_demanded(self, deadline: float) -> None:
        """Instances of negative-only derived predicates for every head that an instance
        negates (transitively: their bodies may negate others)."""
        if not self.demanded_rules:
            return
        pending = [fact for instance in self.instances[self.demand_scan:]
                   for fact in instance.all_demands]
        self.demand_scan = len(self.instances)
        while pending:
            fact = pending.pop()
            if fact in self.demanded_done:
                continue
            self.demanded_done.add(fact)
            check_deadline(deadline)
            for rule in self.demanded_rules[fact[0]]:
                for extended in head_bindings(rule, fact, self.index):
                    instance = self._emit(rule, extended, None)
                    if instance is not None:
                        pending.extend(instance.all_demands)
        self.demand_scan = len(self.instances)

    def _emit(self, rule: _Rule, binding: dict[str, str], delta: list[Fact] | None
              ) -> _Instance | None:
        """Record the instance of ``rule`` for ``binding`` (once), with its open literals."""
        key = (id(rule), tuple([binding[v] for v in rule.variables]))
        if key in self.seen:
            return None
        self.seen.add(key)
        get = binding.get
        for literal in rule.equalities:
            left, right = _ground(literal.args, binding)
            if (left == right) != literal.positive:
                return None
        compiled = rule.compiled
        if compiled is None:
            compiled = rule.compiled = _compile_rule(rule, self.fluent)
        layout = self.layouts.get(id(rule))
        if layout is None:
            layout = self.layouts[id(rule)] = _layout(rule, self.fluent)
        terms_of_positive, dynamic_at, static_at = layout
        fid = self.fact_id
        # Each positive literal grounded once: its id, and as a dynamic or static fact.
        grounded = [(predicate, *[get(a, a) for a in terms])
                    for predicate, terms in terms_of_positive]
        static_neg = tuple([(predicate, *[get(a, a) for a in terms])
                            for predicate, terms in compiled.static_neg])
        instance = _Instance(
            rule, (), tuple([fid(f) for f in grounded]), static_neg,
            tuple([fid(f) for f in static_neg]),
            tuple([grounded[i] for i in dynamic_at]),
            tuple([(predicate, *[get(a, a) for a in terms])
                   for predicate, terms in compiled.dynamic_neg]),
            tuple([grounded[i] for i in static_at]))
        source = rule.source
        demanded = self.on_demand_predicates
        if isinstance(source, NormalAxiom):
            instance.head = (source.predicate, *_ground(source.head_args, binding))
            instance.demands = tuple(f for f in instance.dynamic_neg if f[0] in demanded)
            instance.all_demands = instance.demands
            if delta is None:
                instance.on_demand = True
                self.demand_instances[instance.head].append(instance)
            if self.index.add(instance.head) and delta is not None:
                delta.append(instance.head)
            self.instances.append(instance)
            return instance
        instance.args = tuple([binding[p] for p in source.parameters])
        parts: list[float | Fact] = []
        for amount in source.costs:
            if isinstance(amount, Number):
                parts.append(amount.value)
            elif isinstance(amount, FunctionTerm):
                parts.append((amount.name, *_ground(amount.args, binding)))
        instance.cost_parts = tuple(parts)
        instance.cost_terms = tuple(part for part in parts if isinstance(part, tuple))
        if not instance.cost_terms:
            instance.cost = _summed(parts, {})
        effects = []
        instance.demands = tuple(f for f in instance.dynamic_neg if f[0] in demanded)
        demands = list(instance.demands)
        for effect in source.effects:
            cond_pos, cond_neg, possible = [], [], True
            static_pos, static_neg_ids, static_facts = [], [], []
            for literal in effect.condition:
                if literal.predicate == EQUALITY:
                    left, right = _ground(literal.args, binding)
                    possible &= (left == right) == literal.positive
                    continue
                fact = (literal.predicate, *_ground(literal.args, binding))
                if literal.predicate in self.fluent:
                    (cond_pos if literal.positive else cond_neg).append(fact)
                else:
                    (static_pos if literal.positive else static_neg_ids).append(fid(fact))
                    if literal.positive and not literal.predicate.startswith("type:"):
                        static_facts.append(fact)
            if not possible:
                continue
            fact = (effect.predicate, *[get(a, a) for a in effect.args])
            effect_demands = tuple(f for f in cond_neg if f[0] in demanded)
            effects.append(_Effect(GroundEffect(tuple(cond_pos), tuple(cond_neg), fact,
                                                effect.positive, tuple(static_facts)),
                                   tuple(static_pos), tuple(static_neg_ids), effect_demands))
            demands.extend(effect_demands)
            if effect.positive and self.index.add(fact) and delta is not None:
                delta.append(fact)
        instance.effects = tuple(effects)
        instance.all_demands = tuple(demands)
        instance.plain = instance.cost is not None and not any(
            e.static_pos or e.static_neg or e.demands for e in effects)
        self.instances.append(instance)
        return instance

    # ----------------------------------------------------------------- per-state subset

    def _arrays(self) -> None:
        """Flat arrays of the main (not on-demand) instances: the lists grow with the union
        (only new instances are added), the arrays are made from them when it grew."""
        if self.arrays_for == len(self.instances):
            return
        lists = self.lists
        pre, pre_starts, neg, neg_starts = lists[0], lists[1], lists[2], lists[3]
        rows_owner, rows_fact, rows_positive = lists[4], lists[5], lists[6]
        row_pos, row_pos_starts, row_neg, row_neg_starts = (
            lists[7], lists[8], lists[9], lists[10])
        fid = self.fact_id
        for instance in self.instances[max(self.arrays_for, 0):]:
            number = instance.number = len(self.main)
            self.main.append(instance)
            bisect.insort(self.ranked, (instance.sort_key(), number))
            self.on_demand_list.append(instance.on_demand)
            self.row_bounds.append(len(rows_owner))
            if instance.cost_terms:
                self.cost_terms.append((number, instance))
            pre_starts.append(len(pre))
            pre.extend(instance.positive or (TRUE_ID,))
            neg_starts.append(len(neg))
            neg.extend(instance.static_neg_ids or (FALSE_ID,))
            if instance.head is not None:
                effects: Iterable[tuple[Fact, bool, tuple[int, ...], tuple[int, ...]]] = (
                    (instance.head, True, (), ()),)
            else:
                effects = ((e.effect.fact, e.effect.positive, e.static_pos, e.static_neg)
                           for e in instance.effects)
            for fact, positive, static_pos, static_neg in effects:
                rows_owner.append(number)
                rows_fact.append(fid(fact))
                rows_positive.append(positive)
                row_pos_starts.append(len(row_pos))
                row_pos.extend(static_pos or (TRUE_ID,))
                row_neg_starts.append(len(row_neg))
                row_neg.extend(static_neg or (FALSE_ID,))
        self.arrays_for = len(self.instances)
        self.row_bounds_end = [*self.row_bounds, len(rows_owner)]
        as_int = np.int64
        (self.pre, self.pre_starts, self.neg, self.neg_starts, self.rows_owner,
         self.rows_fact) = (np.asarray(values, dtype=as_int) for values in lists[:6])
        self.rows_positive = np.asarray(rows_positive, dtype=bool)
        self.on_demand_mask = np.asarray(self.on_demand_list, dtype=bool)
        self.order = np.fromiter((number for _, number in self.ranked), dtype=np.int64,
                                 count=len(self.ranked))
        (self.row_pos, self.row_pos_starts, self.row_neg, self.row_neg_starts) = (
            np.asarray(values, dtype=as_int) for values in lists[7:])

    def ground(self, init: set[Fact], function_values: Mapping[Fact, float],
               deadline: float) -> tuple[Grounding, int]:
        """The grounding of ``init`` (already added to the union) and how many instances
        it includes."""
        self._arrays()
        num_facts = len(self.facts)
        state = np.zeros(num_facts, dtype=bool)
        state[TRUE_ID] = True
        ids = self.fact_ids
        state[np.fromiter((ids[f] for f in init if f in ids), dtype=np.int64)] = True
        count = len(self.main)
        static_ok = np.ones(count, dtype=bool)
        if count:
            static_ok &= ~np.maximum.reduceat(state[self.neg], self.neg_starts)
        # Negative-only derived predicates are instantiated on demand, after the fixpoint.
        valid = static_ok & ~self.on_demand_mask
        costs: dict[int, float] = {}
        for number, instance in self.cost_terms:
            if all(term in function_values for term in instance.cost_terms):
                costs[number] = _summed(instance.cost_parts, function_values)
            else:
                valid[number] = False  # undefined cost: not applicable (as in ground_task)
        rows_ok = np.ones(len(self.rows_fact), dtype=bool)
        if len(self.rows_fact):
            rows_ok &= np.minimum.reduceat(state[self.row_pos], self.row_pos_starts)
            rows_ok &= ~np.maximum.reduceat(state[self.row_neg], self.row_neg_starts)
        adding = rows_ok & self.rows_positive
        reach = state.copy()
        fired = np.zeros(count, dtype=bool)
        total = int(reach.sum())
        while count:
            check_deadline(deadline)
            fired = valid & np.minimum.reduceat(reach[self.pre], self.pre_starts)
            reach[self.rows_fact[adding & fired[self.rows_owner]]] = True
            now = int(reach.sum())
            if now == total:
                break
            total = now
        body_ready = np.minimum.reduceat(reach[self.pre], self.pre_starts) if count else fired
        facts = self.facts
        actions: list[GroundAction] = []
        axioms: list[GroundAxiom] = []
        blocked: list[tuple[Fact, tuple[Fact, ...], Fact]] = []
        demanded: list[Fact] = []
        rows_ok_list = rows_ok.tolist()
        bounds = self.row_bounds_end
        ready_list = body_ready.tolist()
        static_list = static_ok.tolist()
        order = self.order
        # In the canonical order: the lists come out sorted.
        for position in order[(body_ready & ~self.on_demand_mask)[order]].tolist():
            instance = self.main[position]
            if not fired[position]:
                if instance.head is not None and not static_list[position]:
                    blocking = next(f for f in instance.static_neg if f in init)
                    blocked.append((instance.head, instance.dynamic_pos, blocking))
                continue
            demanded.extend(instance.demands)
            if instance.head is not None:
                axioms.append(self._axiom(instance))
                continue
            if instance.plain:
                actions.append(self._action(instance, (), instance.cost))  # type: ignore
                continue
            flags = tuple(rows_ok_list[bounds[position]:bounds[position + 1]])
            for effect, ok in zip(instance.effects, flags, strict=True):
                if ok:
                    demanded.extend(effect.demands)
            cost = instance.cost if instance.cost is not None else costs[position]
            actions.append(self._action(instance, flags, cost))
        reachable = set(init)
        reachable.update([facts[i] for i in np.flatnonzero(reach & ~state).tolist()])
        included = len(actions) + len(axioms)
        included_axioms = len(axioms)
        done: set[Fact] = set()
        while demanded:
            fact = demanded.pop()
            if fact in done:
                continue
            done.add(fact)
            for instance in self.demand_instances.get(fact, ()):
                if not ready_list[instance.number]:
                    continue
                if not static_list[instance.number]:
                    blocking = next(f for f in instance.static_neg if f in init)
                    blocked.append((instance.head, instance.dynamic_pos,  # type: ignore
                                    blocking))
                    continue
                axioms.append(self._axiom(instance))
                included += 1
                reachable.add(instance.head)  # type: ignore[arg-type]
                demanded.extend(instance.demands)
        if len(axioms) > included_axioms:  # on-demand ones were added
            axioms = sorted_before(
                axioms, deadline,
                key=lambda a: (a.head, a.body_pos, a.body_neg, a.static_pos))
        grounding = Grounding(actions, axioms, reachable,
                              frozenset({fact[0] for fact in reachable} - self.fluent),
                              self.derived, blocked)
        return grounding, included

    @staticmethod
    def _axiom(instance: _Instance) -> GroundAxiom:
        if instance.built is None:
            instance.built = {(): GroundAxiom(
                instance.head, instance.dynamic_pos,  # type: ignore[arg-type]
                instance.dynamic_neg, instance.static_pos)}
        return instance.built[()]  # type: ignore[return-value]

    @staticmethod
    def _action(instance: _Instance, flags: tuple[bool, ...], cost: float) -> GroundAction:
        """The ground action of ``instance`` with the effects whose ``flags`` are set (all
        of them with ``()``) and ``cost``."""
        key = (flags, cost)
        if instance.built is None:
            instance.built = {}
        built = instance.built.get(key)
        if built is None:
            effects = tuple(e.effect for e, ok in zip(instance.effects, flags, strict=True)
                            if ok) if flags else tuple(e.effect for e in instance.effects)
            built = instance.built[key] = GroundAction(
                instance.rule.source.name, instance.args, instance.dynamic_pos,
                instance.dynamic_neg, effects, cost, instance.static_pos, instance.cost_terms)
        return built  # type: ignore[return-value]


def _summed(parts: Iterable[float | Fact], function_values: Mapping[Fact, float]) -> float:
    """An action's cost: its amounts added in order (numbers, function terms' values)."""
    cost = 0.0
    for part in parts:
        cost += function_values[part] if isinstance(part, tuple) else part
    return cost


def _layout(rule: _Rule, fluent: frozenset[str]
            ) -> tuple[tuple[tuple[str, tuple[str, ...]], ...], tuple[int, ...], tuple[int, ...]]:
    """A rule's positive literals as (predicate, terms), and the positions of the dynamic
    ones and of the static ones other than types (:func:`.ground._compile_rule`'s split)."""
    terms = tuple((lit.predicate, lit.args) for lit in rule.positive)
    dynamic = tuple(i for i, (predicate, _) in enumerate(terms) if predicate in fluent)
    static = tuple(i for i, (predicate, _) in enumerate(terms)
                   if predicate not in fluent and not predicate.startswith("type:"))
    return terms, dynamic, static


class GroundingCache:
    """:func:`.ground_task` for the successive searches of one solve (module docstring).

    Owned by the caller (one per solve); holds the union grounding of the last rule set.
    """

    def __init__(self) -> None:
        self._rules: tuple[tuple[NormalAction, ...], tuple[NormalAxiom, ...]] | None = None
        self._union: _Union | None = None
        self.calls = 0
        self.resets = 0

    def ground(self, actions: Sequence[NormalAction], axioms: Sequence[NormalAxiom],
               init: Iterable[Fact], function_values: Mapping[Fact, float],
               deadline: float) -> Grounding:
        """The same :class:`.Grounding` as ``ground_task(actions, axioms, init, ...)``."""
        self.calls += 1
        rules = (tuple(actions), tuple(axioms))
        facts = set(init)
        if rules != self._rules:
            # The first task of a rule set is grounded from scratch: a union costs ~1.7x
            # that to build (blocksworld's single search: 10 vs 6 ms), and only the tasks
            # after it gain from one.
            self._rules, self._union = rules, None
            return ground_task(actions, axioms, facts, function_values, deadline)
        if self._union is None:
            self._union = _Union(actions, axioms)
        union = self._union
        union.extend(facts, deadline)
        grounding, included = union.ground(facts, function_values, deadline)
        if len(union.instances) > RESET_FACTOR * included + RESET_SLACK:
            self._union = None  # mostly values this solve no longer uses: start again
            self.resets += 1
        return grounding

