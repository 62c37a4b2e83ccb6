"""Normalisation of lifted PDDL into conjunctive rules ready for grounding.

Preconditions and axiom bodies are put in negation normal form and then disjunctive normal
form; each disjunct becomes its own rule (an action variant or an axiom rule). Existential
variables become extra rule variables; universal quantifiers (and existentials under
negation) are expanded over the finite set of objects, which the grounder knows. Types are
encoded as static unary literals ``type:T``.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

from ltamp_cli.errors import InputError, SourceLocation
from ltamp_cli.planner.pddl.syntax import (
    EQUALITY,
    OBJECT_TYPE,
    Action,
    And,
    AndEffect,
    Atom,
    CostExpression,
    DerivedPredicate,
    Effect,
    Exists,
    ForAll,
    ForAllEffect,
    Formula,
    FunctionTerm,
    Imply,
    IncreaseCost,
    Literal,
    Not,
    Or,
    TypedName,
    WhenEffect,
    is_variable,
)

GOAL_PREDICATE = "%goal"
MAX_CLAUSES = 20_000


def type_predicate(type_name: str) -> str:
    return f"type:{type_name}"


@dataclass(frozen=True)
class LiftedLiteral:
    predicate: str
    args: tuple[str, ...]
    positive: bool = True


Clause = tuple[LiftedLiteral, ...]


@dataclass(frozen=True)
class NormalEffect:
    condition: Clause
    predicate: str
    args: tuple[str, ...]
    positive: bool


@dataclass(frozen=True)
class NormalAction:
    """One disjunct of an action: a conjunctive precondition over ``variables``."""

    name: str
    parameters: tuple[str, ...]
    precondition: Clause
    effects: tuple[NormalEffect, ...]
    costs: tuple[CostExpression, ...]  # summed, as PDDL sums repeated increases


@dataclass(frozen=True)
class NormalAxiom:
    predicate: str
    head_args: tuple[str, ...]
    body: Clause


class _Fresh:
    """Fresh variable names, unique within one normalisation."""

    def __init__(self) -> None:
        self.counter = itertools.count()

    def __call__(self, name: str) -> str:
        return f"{name}#{next(self.counter)}"


def _substitute_atom(atom: Atom, mapping: Mapping[str, str]) -> Atom:
    return Atom(atom.predicate, tuple(mapping.get(a, a) for a in atom.args), atom.location)


def substitute(formula: Formula, mapping: Mapping[str, str]) -> Formula:
    """Replace variables by names (objects or other variables) throughout ``formula``."""
    match formula:
        case Atom():
            return _substitute_atom(formula, mapping)
        case Not(part):
            return Not(substitute(part, mapping))
        case And(parts):
            return And(tuple(substitute(p, mapping) for p in parts))
        case Or(parts):
            return Or(tuple(substitute(p, mapping) for p in parts))
        case Imply(condition, consequence):
            return Imply(substitute(condition, mapping), substitute(consequence, mapping))
        case Exists(parameters, body) | ForAll(parameters, body):
            inner = {k: v for k, v in mapping.items() if k not in {p.name for p in parameters}}
            cls = type(formula)
            return cls(parameters, substitute(body, inner))
    raise TypeError(f"not a formula: {formula!r}")


def _product(groups: Sequence[list[Clause]]) -> list[Clause]:
    result: list[Clause] = [()]
    for group in groups:
        result = [left + right for left in result for right in group]
        if len(result) > MAX_CLAUSES:
            raise InputError(
                f"a formula expands to more than {MAX_CLAUSES} disjuncts; simplify it "
                "(e.g. move disjunctions into derived predicates)"
            )
    return result


class Normalizer:
    """DNF conversion with quantifier handling over a fixed object universe."""

    def __init__(self, objects_by_type: Mapping[str, Sequence[str]]) -> None:
        self.objects_by_type = objects_by_type
        self.fresh = _Fresh()
        # Universal conditions become auxiliary derived predicates (as Fast Downward does):
        # forall x. φ  ≡  not aux(free), with aux(free) <- exists x. not φ.
        self.auxiliary: list[NormalAxiom] = []
        self._pending: list[tuple[str, tuple[str, ...], Formula]] = []
        # Auxiliary predicates created in an action precondition -> the action's clauses
        # that use them (see :meth:`take_auxiliary`'s guards).
        self._action_uses: dict[str, list[Clause]] = {}

    def _assignments(self, parameters: Sequence[TypedName]) -> list[dict[str, str]]:
        domains = [self.objects_by_type.get(p.type, ()) for p in parameters]
        return [
            {p.name: value for p, value in zip(parameters, values, strict=True)}
            for values in itertools.product(*domains)
        ]

    def dnf(self, formula: Formula, negated: bool = False, bind_exists: bool = True
            ) -> list[Clause]:
        """Disjunctive normal form of ``formula`` (or of its negation)."""
        match formula:
            case Atom(predicate, args):
                return [(LiftedLiteral(predicate, args, not negated),)]
            case Not(part):
                return self.dnf(part, not negated, bind_exists)
            case And(parts) | Or(parts):
                conjunctive = isinstance(formula, And) != negated
                children = [self.dnf(p, negated, bind_exists) for p in parts]
                if conjunctive:
                    return _product(children)
                return [clause for child in children for clause in child]
            case Imply(condition, consequence):
                return self.dnf(Or((Not(condition), consequence)), negated, bind_exists)
            case Exists(parameters, body) | ForAll(parameters, body):
                existential = isinstance(formula, Exists) != negated
                if not existential and bind_exists:
                    return [(self._universal_literal(formula, negated),)]
                if existential and bind_exists:
                    renaming = {p.name: self.fresh(p.name) for p in parameters}
                    types = tuple(
                        LiftedLiteral(type_predicate(p.type), (renaming[p.name],))
                        for p in parameters
                    )
                    clauses = self.dnf(substitute(body, renaming), negated, bind_exists)
                    return [types + clause for clause in clauses]
                instances = [substitute(body, a) for a in self._assignments(parameters)]
                children = [self.dnf(i, negated, bind_exists) for i in instances]
                if existential:
                    return [clause for child in children for clause in child]
                return _product(children)
        raise TypeError(f"not a formula: {formula!r}")

    def _universal_literal(self, formula: Exists | ForAll, negated: bool) -> LiftedLiteral:
        """Replace a universal condition by ``not aux(free vars)`` and queue aux's rule."""
        free = tuple(sorted(_free_variables(formula)))
        name = f"%forall{len(self._pending) + len(self.auxiliary)}"
        # forall x. φ ≡ not exists x. not φ;   not (exists x. φ) ≡ not aux, aux <- exists x. φ
        counter_body: Formula = (Exists(formula.parameters, Not(formula.body))
                                 if isinstance(formula, ForAll)
                                 else Exists(formula.parameters, formula.body))
        self._pending.append((name, free, counter_body))
        return LiftedLiteral(name, free, False)

    def take_auxiliary(self, static: Callable[[str], bool] | None = None
                       ) -> list[NormalAxiom]:
        """Rules of every auxiliary predicate created so far (and those they create).

        ``static(predicate)`` says which predicates no action changes. With it, the rules of
        an auxiliary predicate that only action preconditions use are *guarded* by the
        static literals of those preconditions over its free variables: ``forall ?m (Contains
        ?c ?m)`` in an action with ``(Cup ?c)`` grounds ``aux(?c)`` for cups only instead of
        for every object (thousands of optimistic objects in TAMP). The guard holds wherever
        the action's static precondition does, so ``not aux`` keeps its meaning there.
        """
        while self._pending:
            name, free, body = self._pending.pop()
            if static is not None:
                body = self._guarded(name, free, body, static)
            types = tuple(LiftedLiteral(type_predicate(OBJECT_TYPE), (v,)) for v in free)
            for clause in self.dnf(body):
                self.auxiliary.append(NormalAxiom(name, free, types + clause))
        rules, self.auxiliary = self.auxiliary, []
        return rules

    def _guarded(self, name: str, free: tuple[str, ...], body: Formula,
                 static: Callable[[str], bool]) -> Formula:
        uses = self._action_uses.get(name)
        if not uses or not free:
            return body
        variables = set(free)
        guards: list[Formula] = []
        for clause in uses:
            guard = tuple(
                Atom(lit.predicate, lit.args) for lit in clause
                if lit.positive and lit.predicate != EQUALITY and static(lit.predicate)
                and lit.predicate != type_predicate(OBJECT_TYPE)
                and any(is_variable(a) for a in lit.args)
                and all(a in variables for a in lit.args if is_variable(a)))
            if not guard:
                return body  # some use is unconstrained: no guard at all
            guards.append(And(guard))
        unique = list(dict.fromkeys(guards))
        condition = unique[0] if len(unique) == 1 else Or(tuple(unique))
        return And((condition, body))

    def effects(self, effect: Effect) -> tuple[list[NormalEffect], list[CostExpression]]:
        match effect:
            case Literal(atom, positive):
                return [NormalEffect((), atom.predicate, atom.args, positive)], []
            case AndEffect(parts):
                effects: list[NormalEffect] = []
                costs: list[CostExpression] = []
                for part in parts:
                    more, more_costs = self.effects(part)
                    effects += more
                    costs += more_costs
                return effects, costs
            case ForAllEffect(parameters, inner):
                effects, costs = [], []
                for assignment in self._assignments(parameters):
                    more, more_costs = self.effects(_substitute_effect(inner, assignment))
                    effects += more
                    costs += more_costs
                return effects, costs
            case WhenEffect(condition, inner):
                clauses = self.dnf(condition, bind_exists=False)
                inner_effects, costs = self.effects(inner)
                if costs:
                    raise InputError("a cost increase inside 'when' is not supported")
                return [
                    NormalEffect(clause + e.condition, e.predicate, e.args, e.positive)
                    for clause in clauses
                    for e in inner_effects
                ], []
            case IncreaseCost(amount):
                return [], [amount]
        raise TypeError(f"not an effect: {effect!r}")

    def action(self, action: Action) -> list[NormalAction]:
        types = tuple(
            LiftedLiteral(type_predicate(p.type), (p.name,)) for p in action.parameters
        )
        with _located(f"action {action.name!r}", action.location):
            effects, costs = self.effects(action.effect)
            parameters = tuple(p.name for p in action.parameters)
            created = len(self._pending)
            clauses = [types + clause for clause in self.dnf(action.precondition)]
        for name, _, _ in self._pending[created:]:
            self._action_uses[name] = [
                clause for clause in clauses
                if any(lit.predicate == name for lit in clause)]
        return [NormalAction(action.name, parameters, clause, tuple(effects), tuple(costs))
                for clause in clauses]

    def axiom(self, axiom: DerivedPredicate) -> list[NormalAxiom]:
        head_args = tuple(p.name for p in axiom.head.parameters)
        types = tuple(
            LiftedLiteral(type_predicate(p.type), (p.name,)) for p in axiom.head.parameters
        )
        rules = []
        with _located(f"derived predicate {axiom.head.name!r}", axiom.location):
            body = self.dnf(axiom.body)
        for clause in body:
            free = _clause_variables(clause) - set(head_args) - _typed_variables(clause)
            # Free body variables without a type literal are existential over all objects.
            extra = tuple(LiftedLiteral(type_predicate(OBJECT_TYPE), (v,)) for v in sorted(free))
            rules.append(NormalAxiom(axiom.head.name, head_args, types + extra + clause))
        return rules

    def goal(self, goal: Formula) -> list[NormalAxiom]:
        rules = []
        try:
            clauses = self.dnf(goal)
        except InputError as error:
            if error.location is not None:
                raise
            raise GoalFormulaError(f"the goal: {error.message}") from None
        for clause in clauses:
            free = _clause_variables(clause) - _typed_variables(clause)
            extra = tuple(LiftedLiteral(type_predicate(OBJECT_TYPE), (v,)) for v in sorted(free))
            rules.append(NormalAxiom(GOAL_PREDICATE, (), extra + clause))
        return rules


class GoalFormulaError(InputError):
    """A refusal of the goal formula found while normalising it (one too large to expand).
    The normaliser does not know where the goal was written: the caller that does
    (:func:`ltamp_cli.planner.api.solve`, from ``PlanningProblem.goal_location``) gives it
    that position."""


@contextmanager
def _located(what: str, location: SourceLocation) -> Iterator[None]:
    """Give an :class:`InputError` raised without a position (a formula too large to expand,
    found while normalising) the position of the action or axiom it came from."""
    try:
        yield
    except InputError as error:
        if error.location is not None:
            raise
        raise InputError(f"{what}: {error.message}", location) from None


def _free_variables(formula: Formula) -> set[str]:
    match formula:
        case Atom(_, args):
            return {a for a in args if is_variable(a)}
        case Not(part):
            return _free_variables(part)
        case And(parts) | Or(parts):
            return set().union(*(_free_variables(p) for p in parts)) if parts else set()
        case Imply(condition, consequence):
            return _free_variables(condition) | _free_variables(consequence)
        case Exists(parameters, body) | ForAll(parameters, body):
            return _free_variables(body) - {p.name for p in parameters}
    raise TypeError(f"not a formula: {formula!r}")


def _clause_variables(clause: Clause) -> set[str]:
    return {arg for literal in clause for arg in literal.args if is_variable(arg)}


def _typed_variables(clause: Clause) -> set[str]:
    return {
        literal.args[0]
        for literal in clause
        if literal.positive and literal.predicate.startswith("type:")
    }


def _substitute_effect(effect: Effect, mapping: Mapping[str, str]) -> Effect:
    match effect:
        case Literal(atom, positive):
            return Literal(_substitute_atom(atom, mapping), positive)
        case AndEffect(parts):
            return AndEffect(tuple(_substitute_effect(p, mapping) for p in parts))
        case ForAllEffect(parameters, inner):
            inner_map = {k: v for k, v in mapping.items() if k not in {p.name for p in parameters}}
            return ForAllEffect(parameters, _substitute_effect(inner, inner_map))
        case WhenEffect(condition, inner):
            return WhenEffect(substitute(condition, mapping), _substitute_effect(inner, mapping))
        case IncreaseCost(amount):
            if isinstance(amount, FunctionTerm):
                args = tuple(mapping.get(a, a) for a in amount.args)
                return IncreaseCost(FunctionTerm(amount.name, args, amount.location))
            return effect
    raise TypeError(f"not an effect: {effect!r}")
