"""PDDL and PDDLStream syntax as frozen dataclasses.

Names are lower-cased (PDDL is case-insensitive). Variables keep their leading ``?``.
Formulas are trees of :class:`Atom`, :class:`Not`, :class:`And`, :class:`Or`,
:class:`Imply`, :class:`Exists` and :class:`ForAll`; equality is the atom with predicate
``"="``. Locations are kept for error messages but excluded from equality.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ltamp_cli.errors import SourceLocation

NO_LOCATION = SourceLocation("<unknown>")
OBJECT_TYPE = "object"
EQUALITY = "="
TOTAL_COST = "total-cost"


def _loc() -> Any:
    """A location field that is left out of equality, hashing and repr."""
    return field(default=NO_LOCATION, compare=False, repr=False)


def is_variable(name: str) -> bool:
    return name.startswith("?")


@dataclass(frozen=True)
class TypedName:
    """A parameter, constant or object with its type."""

    name: str
    type: str = OBJECT_TYPE


@dataclass(frozen=True)
class Atom:
    predicate: str
    args: tuple[str, ...]
    location: SourceLocation = _loc()  # noqa: RUF009

    def __str__(self) -> str:
        return "(" + " ".join((self.predicate, *self.args)) + ")"


@dataclass(frozen=True)
class Not:
    part: Formula


@dataclass(frozen=True)
class And:
    parts: tuple[Formula, ...]


@dataclass(frozen=True)
class Or:
    parts: tuple[Formula, ...]


@dataclass(frozen=True)
class Imply:
    condition: Formula
    consequence: Formula


@dataclass(frozen=True)
class Exists:
    parameters: tuple[TypedName, ...]
    body: Formula


@dataclass(frozen=True)
class ForAll:
    parameters: tuple[TypedName, ...]
    body: Formula


Formula = Atom | Not | And | Or | Imply | Exists | ForAll
TRUE = And(())


@dataclass(frozen=True)
class FunctionTerm:
    """A numeric fluent application such as ``(distance ?q1 ?q2)``."""

    name: str
    args: tuple[str, ...]
    location: SourceLocation = _loc()  # noqa: RUF009


@dataclass(frozen=True)
class Number:
    value: float


CostExpression = FunctionTerm | Number


@dataclass(frozen=True)
class Literal:
    """An add (``positive``) or delete effect."""

    atom: Atom
    positive: bool = True


@dataclass(frozen=True)
class AndEffect:
    parts: tuple[Effect, ...]


@dataclass(frozen=True)
class ForAllEffect:
    parameters: tuple[TypedName, ...]
    effect: Effect


@dataclass(frozen=True)
class WhenEffect:
    condition: Formula
    effect: Effect


@dataclass(frozen=True)
class IncreaseCost:
    amount: CostExpression


Effect = Literal | AndEffect | ForAllEffect | WhenEffect | IncreaseCost


@dataclass(frozen=True)
class PredicateSignature:
    name: str
    parameters: tuple[TypedName, ...]
    location: SourceLocation = _loc()  # noqa: RUF009

    @property
    def arity(self) -> int:
        return len(self.parameters)


@dataclass(frozen=True)
class Action:
    name: str
    parameters: tuple[TypedName, ...]
    precondition: Formula
    effect: Effect
    location: SourceLocation = _loc()  # noqa: RUF009


@dataclass(frozen=True)
class DerivedPredicate:
    """``(:derived (head ?x ...) body)``; body variables not in the head are existential."""

    head: PredicateSignature
    body: Formula
    location: SourceLocation = _loc()  # noqa: RUF009


@dataclass(frozen=True)
class Domain:
    name: str
    requirements: tuple[str, ...]
    types: tuple[tuple[str, str], ...]  # (type, parent) pairs
    constants: tuple[TypedName, ...]
    predicates: tuple[PredicateSignature, ...]
    functions: tuple[PredicateSignature, ...]
    actions: tuple[Action, ...]
    axioms: tuple[DerivedPredicate, ...]
    location: SourceLocation = _loc()  # noqa: RUF009

    def predicate_map(self) -> dict[str, PredicateSignature]:
        signatures = {signature.name: signature for signature in self.predicates}
        for axiom in self.axioms:
            signatures.setdefault(axiom.head.name, axiom.head)
        return signatures

    def function_map(self) -> dict[str, PredicateSignature]:
        return {signature.name: signature for signature in self.functions}

    def derived_predicates(self) -> frozenset[str]:
        return frozenset(axiom.head.name for axiom in self.axioms)

    def type_parents(self) -> dict[str, str]:
        return dict(self.types)


@dataclass(frozen=True)
class FunctionValue:
    """An initial numeric fact ``(= (f a b) value)``."""

    term: FunctionTerm
    value: float


@dataclass(frozen=True)
class Problem:
    name: str
    domain_name: str
    objects: tuple[TypedName, ...]
    init: tuple[Atom, ...]
    function_values: tuple[FunctionValue, ...]
    goal: Formula
    metric_minimize_cost: bool = False
    location: SourceLocation = _loc()  # noqa: RUF009


@dataclass(frozen=True)
class Stream:
    """``(:stream name :inputs :domain :outputs :certified [:fluents])``.

    A ``(:rule :inputs :domain :certified)`` is a stream with ``is_rule`` set: an always-true
    test that is evaluated eagerly (as PDDLStream compiles rules). ``fluent_domain`` holds the
    :domain facts that actions change (PDDLStream's exogenous case): inputs are enumerated
    from the static ``domain`` only, and the certified facts hold only in states where the
    ``fluent_domain`` facts hold (see :func:`~ltamp_cli.planner.pddl.check.prepare_streams`).
    """

    name: str
    inputs: tuple[str, ...]
    domain: tuple[Atom, ...]
    outputs: tuple[str, ...]
    certified: tuple[Atom, ...]
    fluents: tuple[str, ...] = ()
    location: SourceLocation = _loc()  # noqa: RUF009
    is_rule: bool = False
    fluent_domain: tuple[Atom, ...] = ()
    fluents_location: SourceLocation = _loc()  # noqa: RUF009
    # The test this one negates (certifies ``~P`` when that test's binding returns false;
    # see :mod:`ltamp_cli.planner.pddl.negation`), '' for streams of the stream file.
    negates: str = ""

    @property
    def is_test(self) -> bool:
        return not self.outputs


@dataclass(frozen=True)
class StreamFunction:
    """``(:function (f ?x ...) domain)``: a cost function evaluated on stream inputs."""

    head: FunctionTerm
    domain: tuple[Atom, ...]
    location: SourceLocation = _loc()  # noqa: RUF009

    @property
    def name(self) -> str:
        return self.head.name


@dataclass(frozen=True)
class ExternalPredicate:
    """``(:predicate (P ?x ...) domain)``: a test evaluated lazily, usable negated."""

    head: Atom
    domain: tuple[Atom, ...]
    location: SourceLocation = _loc()  # noqa: RUF009
    negates: str = ""  # the predicate this one negates (see Stream.negates)

    @property
    def name(self) -> str:
        return self.head.predicate


@dataclass(frozen=True)
class StreamFile:
    name: str
    streams: tuple[Stream, ...]
    functions: tuple[StreamFunction, ...]
    predicates: tuple[ExternalPredicate, ...]
    location: SourceLocation = _loc()  # noqa: RUF009

    def external_names(self) -> list[str]:
        return [
            *(s.name for s in self.streams),
            *(f.name for f in self.functions),
            *(p.name for p in self.predicates),
        ]


def formula_atoms(formula: Formula) -> list[Atom]:
    """Every atom in a formula, in order of appearance."""
    match formula:
        case Atom():
            return [formula]
        case Not(part):
            return formula_atoms(part)
        case And(parts) | Or(parts):
            return [atom for part in parts for atom in formula_atoms(part)]
        case Imply(condition, consequence):
            return formula_atoms(condition) + formula_atoms(consequence)
        case Exists(_, body) | ForAll(_, body):
            return formula_atoms(body)
    raise TypeError(f"not a formula: {formula!r}")


def effect_atoms(effect: Effect) -> list[tuple[Atom, bool]]:
    """Every (atom, is_add) literal of an effect, including conditional ones."""
    match effect:
        case Literal(atom, positive):
            return [(atom, positive)]
        case AndEffect(parts):
            return [item for part in parts for item in effect_atoms(part)]
        case ForAllEffect(_, inner) | WhenEffect(_, inner):
            return effect_atoms(inner)
        case IncreaseCost():
            return []
    raise TypeError(f"not an effect: {effect!r}")
