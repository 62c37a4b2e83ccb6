"""Negated test facts, as PDDLStream plans with them (its "negated streams").

A predicate ``P`` that only a test stream (or a ``:predicate``) certifies is *absent* until
the test is called. Read as plain PDDL, ``(not (P ...))`` would then hold for values that
were never tested, so a plan could place a box where it collides with another one without
the collision test ever being called. PDDLStream negates such tests automatically (a test
whose fact an action needs false is called on the plan's values, and a true answer blocks
the plan); here the same is compiled into the problem before planning:

* for every such test ``T`` certifying ``P``, a negated test ``~T`` with the same inputs
  and :domain certifies ``(~P ...)`` exactly when ``T``'s binding returns false (the
  binding is derived from ``T``'s, see :func:`ltamp_cli.planner.streams.resolve_bindings`);
* where a formula needs ``P`` false (a precondition, goal or ``when`` condition
  ``(not (P ...))``, the condition of an ``imply``, ...), ``(not (P x))`` becomes
  ``(~P x)``: false until the test has said so;
* inside a derived predicate that a formula needs false (``(not (Unsafe ?p))`` with
  ``Unsafe`` defined from ``P``), a positive ``(P x)`` becomes ``(not (~P x))`` (unsafe
  until tested safe); a derived predicate needed with both signs gets one copy per sign
  that differs from the original.

Predicates with initial facts are left as they are (a fact of ``init`` is not the test's
answer).

Domains that never need such a fact false (every shipped domain: ``tamp2d`` writes its
collision test positively, ``CFree``, and negates a derived predicate) are returned
unchanged, so nothing else is evaluated for them.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

from ltamp_cli.planner.pddl.syntax import (
    EQUALITY,
    AndEffect,
    Atom,
    DerivedPredicate,
    Domain,
    Effect,
    ExternalPredicate,
    ForAllEffect,
    Formula,
    PredicateSignature,
    Stream,
    StreamFile,
    WhenEffect,
    effect_atoms,
)
from ltamp_cli.planner.pddl.syntax import And as _And
from ltamp_cli.planner.pddl.syntax import Exists as _Exists
from ltamp_cli.planner.pddl.syntax import ForAll as _ForAll
from ltamp_cli.planner.pddl.syntax import Imply as _Imply
from ltamp_cli.planner.pddl.syntax import Not as _Not
from ltamp_cli.planner.pddl.syntax import Or as _Or

NEGATED_PREFIX = "~"


def negated_name(name: str) -> str:
    """The name of the negated test (or predicate) of ``name``."""
    return NEGATED_PREFIX + name


def tested_predicates(domain: Domain, streams: StreamFile, initial: Iterable[str] = ()
                      ) -> dict[str, str]:
    """Predicate -> the one test stream or ``:predicate`` that certifies it, for predicates
    that nothing else makes true (no other stream, no action effect, no axiom). Rules,
    ``:fluents`` tests and exogenous tests (their facts depend on the state) are left out."""
    certifiers: dict[str, list[str]] = {}
    eligible: set[str] = set()
    for stream in streams.streams:
        for atom in stream.certified:
            certifiers.setdefault(atom.predicate, []).append(stream.name)
        if (stream.is_test and not stream.is_rule and not stream.fluents
                and not stream.fluent_domain and stream.certified and not stream.negates):
            eligible.add(stream.name)
    for predicate in streams.predicates:
        certifiers.setdefault(predicate.name, []).append(predicate.name)
        if not predicate.negates:
            eligible.add(predicate.name)
    changed = {atom.predicate for action in domain.actions
               for atom, _ in effect_atoms(action.effect)}
    derived = domain.derived_predicates()
    changed.update(initial)
    return {predicate: sources[0] for predicate, sources in certifiers.items()
            if len(sources) == 1 and sources[0] in eligible and predicate not in changed
            and predicate not in derived and predicate != EQUALITY}


class _Compiler:
    """Rewrites formulas by the sign they are needed with (see the module docstring)."""

    def __init__(self, domain: Domain, tested: dict[str, str]) -> None:
        self.tested = tested
        self.axioms: dict[str, list[DerivedPredicate]] = {}
        for axiom in domain.axioms:
            self.axioms.setdefault(axiom.head.name, []).append(axiom)
        self.affects = self._affected()
        self.needed: set[tuple[str, bool]] = set()
        self.negated: set[str] = set()  # tested predicates needed false somewhere

    def _affected(self) -> dict[tuple[str, bool], bool]:
        """Whether rewriting a derived predicate's bodies for a sign changes them (least
        fixpoint: recursive derived predicates are resolved by iteration)."""
        affects = {(name, sign): False for name in self.axioms for sign in (True, False)}
        changed = True
        while changed:
            changed = False
            for (name, sign), value in affects.items():
                if value:
                    continue
                if any(self._mentions(axiom.body, sign, affects)
                       for axiom in self.axioms[name]):
                    affects[(name, sign)] = True
                    changed = True
        return affects

    def _mentions(self, formula: Formula, want_true: bool,
                  affects: dict[tuple[str, bool], bool]) -> bool:
        match formula:
            case Atom(predicate=predicate):
                if predicate in self.tested:
                    return not want_true
                return affects.get((predicate, want_true), False)
            case _Not(part):
                return self._mentions(part, not want_true, affects)
            case _And(parts) | _Or(parts):
                return any(self._mentions(part, want_true, affects) for part in parts)
            case _Imply(condition, consequence):
                return (self._mentions(condition, not want_true, affects)
                        or self._mentions(consequence, want_true, affects))
            case _Exists(_, body) | _ForAll(_, body):
                return self._mentions(body, want_true, affects)
        raise TypeError(f"not a formula: {formula!r}")

    def derived_name(self, name: str, want_true: bool) -> str:
        if not self.affects.get((name, want_true), False):
            return name
        return f"{name}{NEGATED_PREFIX}{'t' if want_true else 'f'}"

    def formula(self, formula: Formula, want_true: bool) -> Formula:
        match formula:
            case Atom(predicate=predicate, args=args, location=location):
                if predicate in self.tested:
                    if want_true:
                        return formula
                    self.negated.add(predicate)
                    # needed false: false only once the negated test has certified it.
                    # (P x) itself is left out: the optimistic evaluation assumes every
                    # test succeeds, which would make it true before anything is called.
                    return _Not(Atom(negated_name(predicate), args, location))
                if predicate in self.axioms:
                    self.needed.add((predicate, want_true))
                    name = self.derived_name(predicate, want_true)
                    return formula if name == predicate else Atom(name, args, location)
                return formula
            case _Not(part):
                inner = self.formula(part, not want_true)
                return inner.part if isinstance(inner, _Not) else _Not(inner)
            case _And(parts):
                return _And(tuple(self.formula(part, want_true) for part in parts))
            case _Or(parts):
                return _Or(tuple(self.formula(part, want_true) for part in parts))
            case _Imply(condition, consequence):
                return _Imply(self.formula(condition, not want_true),
                              self.formula(consequence, want_true))
            case _Exists(parameters, body):
                return _Exists(parameters, self.formula(body, want_true))
            case _ForAll(parameters, body):
                return _ForAll(parameters, self.formula(body, want_true))
        raise TypeError(f"not a formula: {formula!r}")

    def effect(self, effect: Effect) -> Effect:
        match effect:
            case AndEffect(parts):
                return AndEffect(tuple(self.effect(part) for part in parts))
            case ForAllEffect(parameters, inner):
                return ForAllEffect(parameters, self.effect(inner))
            case WhenEffect(condition, inner):
                return WhenEffect(self.formula(condition, True), self.effect(inner))
        return effect

    def derived(self) -> list[DerivedPredicate]:
        """The axioms of every needed (derived predicate, sign), rewritten for that sign."""
        done: set[tuple[str, bool]] = set()
        emitted: set[str] = set()
        result: list[DerivedPredicate] = []
        while self.needed - done:
            name, sign = sorted(self.needed - done)[0]
            done.add((name, sign))
            head_name = self.derived_name(name, sign)
            if head_name in emitted:
                continue
            emitted.add(head_name)
            for axiom in self.axioms[name]:
                body = self.formula(axiom.body, sign)
                head = (axiom.head if head_name == name
                        else replace(axiom.head, name=head_name))
                result.append(replace(axiom, head=head, body=body))
        return result


def guard_negated_tests(domain: Domain, streams: StreamFile, goals: Iterable[Formula] = (),
                        initial: Iterable[str] = ()
                        ) -> tuple[Domain, StreamFile, list[Formula]]:
    """The domain, stream file and goals with negated test facts compiled as in PDDLStream
    (module docstring; ``initial``: the predicates of the initial facts); unchanged when no
    formula needs such a fact false."""
    goals = list(goals)
    tested = tested_predicates(domain, streams, initial)
    if not tested:
        return domain, streams, goals
    compiler = _Compiler(domain, tested)
    actions = [replace(action, precondition=compiler.formula(action.precondition, True),
                       effect=compiler.effect(action.effect))
               for action in domain.actions]
    new_goals = [compiler.formula(goal, True) for goal in goals]
    axioms = compiler.derived()
    emitted = {axiom.head.name for axiom in axioms}
    # axioms that no action or goal reaches stay as written
    axioms += [axiom for axiom in domain.axioms if axiom.head.name not in emitted
               and not any(name == axiom.head.name for name, _ in compiler.needed)]
    if not compiler.negated:
        return domain, streams, goals
    signatures = domain.predicate_map()
    added_predicates = [
        PredicateSignature(negated_name(predicate), signatures[predicate].parameters,
                           signatures[predicate].location)
        for predicate in sorted(compiler.negated)]
    for axiom in axioms:
        if axiom.head.name not in signatures:
            added_predicates.append(axiom.head)
            signatures[axiom.head.name] = axiom.head
    new_streams: list[Stream] = []
    new_predicates: list[ExternalPredicate] = []
    for stream in streams.streams:
        negated = tuple(Atom(negated_name(atom.predicate), atom.args, atom.location)
                        for atom in stream.certified if atom.predicate in compiler.negated
                        and tested[atom.predicate] == stream.name)
        if negated:
            new_streams.append(replace(stream, name=negated_name(stream.name),
                                       certified=negated, negates=stream.name))
    for predicate in streams.predicates:
        if predicate.name in compiler.negated:
            head = Atom(negated_name(predicate.name), predicate.head.args,
                        predicate.head.location)
            new_predicates.append(replace(predicate, head=head, negates=predicate.name))
    new_domain = replace(domain, predicates=(*domain.predicates, *added_predicates),
                         actions=tuple(actions), axioms=tuple(axioms))
    new_stream_file = replace(streams, streams=(*streams.streams, *new_streams),
                              predicates=(*streams.predicates, *new_predicates))
    return new_domain, new_stream_file, new_goals


__all__ = ["NEGATED_PREFIX", "guard_negated_tests", "negated_name", "tested_predicates"]
