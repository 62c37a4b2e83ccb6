"""Parsers from PDDL / PDDLStream text to :mod:`.syntax` objects.

Parsing checks only the *shape* of the text; names are resolved by :mod:`.check`.
Every error is an :class:`~ltamp_cli.errors.InputError` at ``file:line:column``.
"""

from __future__ import annotations

import math
from pathlib import Path

from ltamp_cli.errors import InputError, SourceLocation
from ltamp_cli.planner.pddl.sexpr import SExpr, SList, Symbol, read_one, read_sexprs
from ltamp_cli.planner.pddl.syntax import (
    EQUALITY,
    OBJECT_TYPE,
    TRUE,
    Action,
    And,
    AndEffect,
    Atom,
    CostExpression,
    DerivedPredicate,
    Domain,
    Effect,
    Exists,
    ExternalPredicate,
    ForAll,
    ForAllEffect,
    Formula,
    FunctionTerm,
    FunctionValue,
    Imply,
    IncreaseCost,
    Literal,
    Not,
    Number,
    Or,
    PredicateSignature,
    Problem,
    Stream,
    StreamFile,
    StreamFunction,
    TypedName,
    WhenEffect,
    is_variable,
)
from ltamp_cli.textfile import MAX_PDDL_BYTES, read_limited_text


def _expect_list(expr: SExpr, what: str) -> SList:
    if not isinstance(expr, SList):
        raise InputError(f"expected '(' starting {what}, found {expr.text!r}", expr.location)
    return expr


def _expect_symbol(expr: SExpr, what: str) -> str:
    if not isinstance(expr, Symbol):
        raise InputError(f"expected {what}, found a list", expr.location)
    return expr.text.lower()


def _expect_name(expr: SExpr, what: str) -> str:
    name = _expect_symbol(expr, what)
    if name.startswith((":", "?")) or name in ("(", ")"):
        raise InputError(f"expected {what}, found {name!r}", expr.location)
    return name


def _expect_variable(expr: SExpr, what: str) -> str:
    name = _expect_symbol(expr, what)
    if not is_variable(name) or len(name) < 2:
        raise InputError(f"expected {what} (a '?variable'), found {name!r}", expr.location)
    return name


def _keyword_sections(
    items: tuple[SExpr, ...], allowed: tuple[str, ...], what: str
) -> dict[str, tuple[SExpr, SourceLocation]]:
    """Read ``:key value`` pairs; each value is one s-expression."""
    sections: dict[str, tuple[SExpr, SourceLocation]] = {}
    index = 0
    while index < len(items):
        key_expr = items[index]
        key = _expect_symbol(key_expr, f"a keyword of {what} ({', '.join(allowed)})")
        if key not in allowed:
            raise InputError(
                f"unexpected {key!r} in {what}: expected one of {', '.join(allowed)}",
                key_expr.location,
            )
        if key in sections:
            raise InputError(f"{key} given twice in {what}", key_expr.location)
        if index + 1 >= len(items):
            raise InputError(f"{key} needs a value in {what}", key_expr.location)
        sections[key] = (items[index + 1], key_expr.location)
        index += 2
    return sections


def parse_typed_list(items: tuple[SExpr, ...], variables: bool, what: str) -> list[TypedName]:
    """``a b - type c`` → typed names; ``variables`` requires ``?x`` names."""
    result: list[TypedName] = []
    pending: list[str] = []
    index = 0
    while index < len(items):
        item = items[index]
        if isinstance(item, Symbol) and item.text == "-":
            if not pending:
                raise InputError(f"'-' with no names before it in {what}", item.location)
            if index + 1 >= len(items):
                raise InputError(f"expected a type name after '-' in {what}", item.location)
            type_expr = items[index + 1]
            if isinstance(type_expr, SList) and type_expr.head() == "either":
                raise InputError("'either' types are not supported", type_expr.location)
            type_name = _expect_name(type_expr, f"a type name in {what}")
            result.extend(TypedName(name, type_name) for name in pending)
            pending = []
            index += 2
            continue
        if variables:
            pending.append(_expect_variable(item, f"a parameter of {what}"))
        else:
            pending.append(_expect_name(item, f"a name in {what}"))
        index += 1
    result.extend(TypedName(name, OBJECT_TYPE) for name in pending)
    return result


def _parameters(expr: SExpr, what: str) -> tuple[TypedName, ...]:
    node = _expect_list(expr, f"the parameters of {what}")
    return tuple(parse_typed_list(node.items, True, what))


def parse_atom(expr: SExpr, what: str, allow_variables: bool = True) -> Atom:
    node = _expect_list(expr, what)
    if not node.items:
        raise InputError(f"empty list where {what} was expected", node.location)
    predicate = _expect_symbol(node.items[0], f"a predicate name in {what}")
    if predicate.startswith((":", "?")):
        raise InputError(f"expected a predicate name in {what}, found {predicate!r}",
                         node.items[0].location)
    args = []
    for item in node.items[1:]:
        name = _expect_symbol(item, f"an argument of ({predicate} ...)")
        if name.startswith(":"):
            raise InputError(f"unexpected keyword {name!r} as an argument", item.location)
        if is_variable(name) and not allow_variables:
            raise InputError(f"variable {name!r} is not allowed in {what}", item.location)
        args.append(name)
    return Atom(predicate, tuple(args), node.location)


_CONNECTIVES = ("and", "or", "not", "imply", "exists", "forall")
_COMPARISONS = ("<", ">", "<=", ">=")


def parse_formula(expr: SExpr, what: str = "a formula") -> Formula:
    node = _expect_list(expr, what)
    head = node.head()
    if head is None and not node.items:
        return TRUE
    if head == "and":
        return And(tuple(parse_formula(item, what) for item in node.items[1:]))
    if head == "or":
        return Or(tuple(parse_formula(item, what) for item in node.items[1:]))
    if head == "not":
        if len(node.items) != 2:
            raise InputError("'not' takes exactly one formula", node.location)
        return Not(parse_formula(node.items[1], what))
    if head == "imply":
        if len(node.items) != 3:
            raise InputError("'imply' takes exactly two formulas", node.location)
        return Imply(parse_formula(node.items[1], what), parse_formula(node.items[2], what))
    if head in ("exists", "forall"):
        if len(node.items) != 3:
            raise InputError(f"'{head}' takes a parameter list and one formula", node.location)
        parameters = _parameters(node.items[1], f"'{head}'")
        body = parse_formula(node.items[2], what)
        return Exists(parameters, body) if head == "exists" else ForAll(parameters, body)
    if head in _COMPARISONS or (head == EQUALITY and any(
            isinstance(item, SList) for item in node.items[1:])):
        # PDDLStream's numeric fluents are action costs only; a comparison of function terms
        # used to be read as a predicate named '>=' ("expected an argument, found a list")
        raise InputError(f"numeric condition ({head} ...) in {what} is not supported: "
                         "functions (:functions) may only give action costs, "
                         "(increase (total-cost) ...)", node.location)
    if head == EQUALITY:
        atom = parse_atom(node, what)
        if len(atom.args) != 2:
            raise InputError("'=' takes exactly two arguments", node.location)
        return atom
    return parse_atom(node, what)


def _cost_number(symbol: Symbol, what: str) -> float:
    """A cost written as a number: finite and >= 0 (``ValueError`` if not a number at all).
    ``float`` also reads ``nan``, ``inf`` and ``-5``, and overflows ``1e400`` to ``inf``:
    the search then answered "no plan" without a word."""
    value = float(symbol.text)
    if not math.isfinite(value) or value < 0:
        raise InputError(f"{what} must be a finite number >= 0, found {symbol.text[:40]!r}",
                         symbol.location)
    return value


def _parse_cost_expression(expr: SExpr) -> CostExpression:
    if isinstance(expr, Symbol):
        try:
            return Number(_cost_number(expr, "an action cost"))
        except ValueError:
            raise InputError(
                f"expected a number or a function term as a cost, found {expr.text!r}",
                expr.location,
            ) from None
    head = expr.head()
    if head is None:
        raise InputError("expected a function term such as (distance ?a ?b)", expr.location)
    args = tuple(_expect_symbol(item, "a function argument") for item in expr.items[1:])
    return FunctionTerm(head, args, expr.location)


def parse_effect(expr: SExpr, what: str = "an effect", in_when: bool = False) -> Effect:
    """An effect; ``in_when``: inside a ``when``, where a cost increase is refused here, at
    its position (the planner's costs are per action, not per conditional effect)."""
    node = _expect_list(expr, what)
    head = node.head()
    if head is None and not node.items:
        return AndEffect(())
    if head == "and":
        return AndEffect(tuple(parse_effect(item, what, in_when) for item in node.items[1:]))
    if head == "not":
        if len(node.items) != 2:
            raise InputError("'not' takes exactly one atom", node.location)
        return Literal(parse_atom(node.items[1], "a delete effect"), positive=False)
    if head == "forall":
        if len(node.items) != 3:
            raise InputError("'forall' takes a parameter list and one effect", node.location)
        return ForAllEffect(_parameters(node.items[1], "'forall'"),
                            parse_effect(node.items[2], in_when=in_when))
    if head == "when":
        if len(node.items) != 3:
            raise InputError("'when' takes a condition and an effect", node.location)
        return WhenEffect(parse_formula(node.items[1], "a 'when' condition"),
                          parse_effect(node.items[2], in_when=True))
    if head == "increase":
        if len(node.items) != 3:
            raise InputError("'increase' takes (total-cost) and an amount", node.location)
        target = node.items[1]
        if not (isinstance(target, SList) and target.head() == "total-cost" and len(target) == 1):
            raise InputError("only (increase (total-cost) ...) is supported", target.location)
        if in_when:
            raise InputError("a cost increase inside 'when' is not supported: an action's "
                             "cost must not depend on its state", node.location)
        return IncreaseCost(_parse_cost_expression(node.items[2]))
    if head in ("decrease", "assign", "scale-up", "scale-down"):
        raise InputError(f"numeric effect '{head}' is not supported (only increase total-cost)",
                         node.location)
    if head in _CONNECTIVES:
        raise InputError(f"'{head}' is not allowed in an effect", node.location)
    return Literal(parse_atom(node, what))


def _signature(expr: SExpr, what: str) -> PredicateSignature:
    node = _expect_list(expr, what)
    if not node.items:
        raise InputError(f"empty {what}", node.location)
    name = _expect_name(node.items[0], f"the name of {what}")
    parameters = tuple(parse_typed_list(node.items[1:], True, what))
    return PredicateSignature(name, parameters, node.location)


def _parse_action(node: SList) -> Action:
    if len(node.items) < 2:
        raise InputError("an action needs a name", node.location)
    name = _expect_name(node.items[1], "an action name")
    sections = _keyword_sections(
        node.items[2:], (":parameters", ":precondition", ":effect"), f"action {name!r}"
    )
    parameters = (
        _parameters(sections[":parameters"][0], f"action {name!r}")
        if ":parameters" in sections else ()
    )
    precondition = (
        parse_formula(sections[":precondition"][0], f"the precondition of {name!r}")
        if ":precondition" in sections else TRUE
    )
    if ":effect" not in sections:
        raise InputError(f"action {name!r} has no :effect", node.location)
    effect = parse_effect(sections[":effect"][0], f"the effect of {name!r}")
    return Action(name, parameters, precondition, effect, node.location)


def parse_domain(text: str, path: str | Path) -> Domain:
    """Parse a PDDL domain file's text."""
    path = str(path)
    root = read_one(text, path, "(define (domain ...) ...)")
    if root.head() != "define" or len(root.items) < 2:
        raise InputError("expected (define (domain NAME) ...)", root.location)
    header = _expect_list(root.items[1], "(domain NAME)")
    if header.head() != "domain" or len(header.items) != 2:
        raise InputError("expected (domain NAME)", header.location)
    name = _expect_name(header.items[1], "a domain name")
    requirements: list[str] = []
    types: list[tuple[str, str]] = []
    constants: list[TypedName] = []
    predicates: list[PredicateSignature] = []
    functions: list[PredicateSignature] = []
    actions: list[Action] = []
    axioms: list[DerivedPredicate] = []
    for item in root.items[2:]:
        section = _expect_list(item, "a domain section such as (:predicates ...)")
        key = section.head()
        body = section.items[1:]
        if key == ":requirements":
            requirements.extend(_expect_symbol(r, "a requirement") for r in body)
        elif key == ":types":
            for typed in parse_typed_list(body, False, ":types"):
                types.append((typed.name, typed.type))
        elif key == ":constants":
            constants.extend(parse_typed_list(body, False, ":constants"))
        elif key == ":predicates":
            predicates.extend(_signature(p, "a predicate declaration") for p in body)
        elif key == ":functions":
            index = 0
            while index < len(body):
                entry = body[index]
                if isinstance(entry, Symbol) and entry.text == "-":
                    index += 2  # "- number" after a function declaration
                    continue
                functions.append(_signature(entry, "a function declaration"))
                index += 1
        elif key == ":action":
            actions.append(_parse_action(section))
        elif key == ":derived":
            if len(section.items) != 3:
                raise InputError("expected (:derived (PREDICATE ?x ...) FORMULA)",
                                 section.location)
            head = _signature(section.items[1], "a derived predicate head")
            axioms.append(DerivedPredicate(head, parse_formula(section.items[2]),
                                           section.location))
        else:
            raise InputError(
                f"unknown domain section {key!r}: expected :requirements, :types, :constants, "
                ":predicates, :functions, :action or :derived",
                section.location,
            )
    return Domain(name, tuple(requirements), tuple(types), tuple(constants), tuple(predicates),
                  tuple(functions), tuple(actions), tuple(axioms), root.location)


def parse_init_item(expr: SExpr) -> Atom | FunctionValue:
    """An initial fact ``(p a b)`` or numeric assignment ``(= (f a) 3.5)``."""
    node = _expect_list(expr, "an initial fact")
    if node.head() == EQUALITY and len(node.items) == 3 and isinstance(node.items[1], SList):
        term = _parse_cost_expression(node.items[1])
        value_expr = node.items[2]
        if not isinstance(term, FunctionTerm) or not isinstance(value_expr, Symbol):
            raise InputError("expected (= (FUNCTION args) NUMBER)", node.location)
        try:
            value = _cost_number(value_expr, "a function value (functions give action costs)")
        except ValueError:
            raise InputError(f"expected a number, found {value_expr.text!r}",
                             value_expr.location) from None
        return FunctionValue(term, value)
    return parse_atom(node, "an initial fact", allow_variables=False)


def parse_problem(text: str, path: str | Path) -> Problem:
    """Parse a PDDL problem file's text."""
    path = str(path)
    root = read_one(text, path, "(define (problem ...) ...)")
    if root.head() != "define" or len(root.items) < 2:
        raise InputError("expected (define (problem NAME) ...)", root.location)
    header = _expect_list(root.items[1], "(problem NAME)")
    if header.head() != "problem" or len(header.items) != 2:
        raise InputError("expected (problem NAME)", header.location)
    name = _expect_name(header.items[1], "a problem name")
    domain_name = ""
    objects: list[TypedName] = []
    init: list[Atom] = []
    values: list[FunctionValue] = []
    goal: Formula | None = None
    minimize = False
    for item in root.items[2:]:
        section = _expect_list(item, "a problem section such as (:init ...)")
        key = section.head()
        body = section.items[1:]
        if key == ":domain":
            if len(body) != 1:
                raise InputError("expected (:domain NAME)", section.location)
            domain_name = _expect_name(body[0], "a domain name")
        elif key == ":requirements":
            continue
        elif key == ":objects":
            objects.extend(parse_typed_list(body, False, ":objects"))
        elif key == ":init":
            for fact in body:
                parsed = parse_init_item(fact)
                (values if isinstance(parsed, FunctionValue) else init).append(parsed)
        elif key == ":goal":
            if len(body) != 1:
                raise InputError("expected (:goal FORMULA)", section.location)
            goal = parse_formula(body[0], "the goal")
        elif key == ":metric":
            # the planner minimises the plan's total cost: anything else would be ignored
            direction = body[0].text.lower() if body and isinstance(body[0], Symbol) else ""
            if direction != "minimize":
                raise InputError("only (:metric minimize (total-cost)) is supported, got "
                                 f"(:metric {' '.join(str(b) for b in body)[:60]})",
                                 section.location)
            minimize = True
        else:
            raise InputError(
                f"unknown problem section {key!r}: expected :domain, :objects, :init, :goal "
                "or :metric",
                section.location,
            )
    if goal is None:
        raise InputError("the problem has no (:goal ...)", root.location)
    return Problem(name, domain_name, tuple(objects), tuple(init), tuple(values), goal, minimize,
                   root.location)


def _conjunction_atoms(expr: SExpr, what: str) -> tuple[Atom, ...]:
    formula = parse_formula(expr, what)
    parts = formula.parts if isinstance(formula, And) else (formula,)
    atoms: list[Atom] = []
    for part in parts:
        if not isinstance(part, Atom):
            location = getattr(expr, "location", None)
            raise InputError(f"{what} must be a conjunction of atoms", location)
        atoms.append(part)
    return tuple(atoms)


def _variable_list(expr: SExpr, what: str) -> tuple[str, ...]:
    node = _expect_list(expr, what)
    return tuple(_expect_variable(item, what) for item in node.items)


def _parse_stream(node: SList) -> Stream:
    if len(node.items) < 2:
        raise InputError("a stream needs a name", node.location)
    name = _expect_name(node.items[1], "a stream name")
    sections = _keyword_sections(
        node.items[2:],
        (":inputs", ":domain", ":outputs", ":certified", ":fluents"),
        f"stream {name!r}",
    )
    inputs = _variable_list(sections[":inputs"][0], f"the inputs of {name!r}") \
        if ":inputs" in sections else ()
    outputs = _variable_list(sections[":outputs"][0], f"the outputs of {name!r}") \
        if ":outputs" in sections else ()
    domain = _conjunction_atoms(sections[":domain"][0], f"the :domain of {name!r}") \
        if ":domain" in sections else ()
    # No :certified: a stream whose calls certify only wild facts (PDDLStream accepts it).
    certified = _conjunction_atoms(sections[":certified"][0], f"the :certified of {name!r}") \
        if ":certified" in sections else ()
    fluents: tuple[str, ...] = ()
    fluents_location = node.location
    if ":fluents" in sections:
        fluent_node = _expect_list(sections[":fluents"][0], f"the :fluents of {name!r}")
        fluents = tuple(_expect_name(item, "a fluent predicate") for item in fluent_node.items)
        fluents_location = sections[":fluents"][1]
    return Stream(name, inputs, domain, outputs, certified, fluents, node.location,
                  fluents_location=fluents_location)


def _parse_rule(node: SList, index: int) -> Stream:
    """``(:rule :inputs (?x ...) :domain (...) :certified (...))``: an always-true eager test
    named ``:rule{index}`` (a name no stream file can declare)."""
    name = f":rule{index}"
    sections = _keyword_sections(node.items[1:], (":inputs", ":domain", ":certified"), "a rule")
    inputs = _variable_list(sections[":inputs"][0], "the inputs of a rule") \
        if ":inputs" in sections else ()
    domain = _conjunction_atoms(sections[":domain"][0], "the :domain of a rule") \
        if ":domain" in sections else ()
    if ":certified" not in sections:
        raise InputError("a rule has no :certified facts", node.location)
    certified = _conjunction_atoms(sections[":certified"][0], "the :certified of a rule")
    return Stream(name, inputs, domain, (), certified, (), node.location, is_rule=True)


def _parse_external(node: SList, kind: str) -> StreamFunction | ExternalPredicate:
    if len(node.items) not in (2, 3):
        raise InputError(f"expected ({kind} (NAME ?x ...) [DOMAIN])", node.location)
    head = parse_atom(node.items[1], f"the head of a {kind}")
    domain = _conjunction_atoms(node.items[2], f"the domain of {head.predicate!r}") \
        if len(node.items) == 3 else ()
    for arg in head.args:
        if not is_variable(arg):
            raise InputError(f"the head of a {kind} takes ?variables, found {arg!r}",
                             head.location)
    if kind == ":function":
        return StreamFunction(FunctionTerm(head.predicate, head.args, head.location), domain,
                              node.location)
    return ExternalPredicate(head, domain, node.location)


def parse_stream_file(text: str, path: str | Path) -> StreamFile:
    """Parse a PDDLStream stream file: ``(define (stream NAME) (:stream ...) ...)``."""
    path = str(path)
    exprs = read_sexprs(text, path)
    if not exprs:
        raise InputError("empty stream file: expected (define (stream NAME) ...)",
                         SourceLocation(path, 1, 1))
    root = _expect_list(exprs[0], "(define (stream NAME) ...)")
    if root.head() != "define" or len(root.items) < 2:
        raise InputError("expected (define (stream NAME) ...)", root.location)
    header = _expect_list(root.items[1], "(stream NAME)")
    if header.head() != "stream" or len(header.items) != 2:
        raise InputError("expected (stream NAME)", header.location)
    if len(exprs) > 1:
        raise InputError("unexpected text after the stream definition", exprs[1].location)
    name = _expect_name(header.items[1], "a stream-file name")
    streams: list[Stream] = []
    functions: list[StreamFunction] = []
    predicates: list[ExternalPredicate] = []
    for item in root.items[2:]:
        section = _expect_list(item, "a stream declaration such as (:stream ...)")
        key = section.head()
        if key == ":stream":
            streams.append(_parse_stream(section))
        elif key == ":rule":
            streams.append(_parse_rule(section, sum(s.is_rule for s in streams)))
        elif key == ":function":
            function = _parse_external(section, ":function")
            assert isinstance(function, StreamFunction)
            functions.append(function)
        elif key == ":predicate":
            predicate = _parse_external(section, ":predicate")
            assert isinstance(predicate, ExternalPredicate)
            predicates.append(predicate)
        else:
            raise InputError(
                f"unknown stream-file section {key!r}: expected :stream, :rule, :function or "
                ":predicate",
                section.location,
            )
    return StreamFile(name, tuple(streams), tuple(functions), tuple(predicates), root.location)


def read_text(path: str | Path, what: str) -> str:
    """A PDDL file's text (at most :data:`~ltamp_cli.textfile.MAX_PDDL_BYTES`: ``/dev/zero``
    or a FIFO is refused instead of read forever)."""
    return read_limited_text(path, MAX_PDDL_BYTES, what)
