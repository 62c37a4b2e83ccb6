"""Semantic checks: names, arities and types of parsed domains, problems and stream files.

Parsing (:mod:`.parse`) checks shape; these functions check meaning and report the first
problem as an :class:`~ltamp_cli.errors.InputError` at its source location.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

from ltamp_cli.errors import InputError, SourceLocation
from ltamp_cli.planner.pddl.syntax import (
    EQUALITY,
    OBJECT_TYPE,
    And,
    Atom,
    Domain,
    Effect,
    ForAllEffect,
    Formula,
    FunctionTerm,
    Imply,
    IncreaseCost,
    Not,
    Or,
    PredicateSignature,
    Problem,
    StreamFile,
    TypedName,
    effect_atoms,
    formula_atoms,
    is_variable,
)
from ltamp_cli.planner.pddl.syntax import (
    Exists as _Exists,
)
from ltamp_cli.planner.pddl.syntax import (
    ForAll as _ForAll,
)


def _known_types(domain: Domain) -> set[str]:
    return {OBJECT_TYPE, *(child for child, _ in domain.types), *(p for _, p in domain.types)}


def _check_types(names: Iterable[TypedName], known: set[str], location: SourceLocation) -> None:
    for typed in names:
        if typed.type not in known:
            raise InputError(
                f"unknown type {typed.type!r} for {typed.name!r}: expected one of "
                f"{', '.join(sorted(known))}",
                location,
            )


def _check_atom(atom: Atom, arities: dict[str, int], scope: set[str] | None,
                constants: set[str] | None, what: str) -> None:
    if atom.predicate == EQUALITY:
        expected = 2
    elif atom.predicate not in arities:
        raise InputError(f"unknown predicate {atom.predicate!r} in {what}", atom.location)
    else:
        expected = arities[atom.predicate]
    if len(atom.args) != expected:
        raise InputError(
            f"predicate {atom.predicate!r} takes {expected} argument(s), got {len(atom.args)} "
            f"in {what}",
            atom.location,
        )
    for arg in atom.args:
        if is_variable(arg):
            if scope is not None and arg not in scope:
                raise InputError(f"variable {arg} is not a parameter in {what}", atom.location)
        elif constants is not None and arg not in constants:
            raise InputError(f"unknown object {arg!r} in {what}", atom.location)


def _quantified_variables(formula: object) -> set[str]:
    """Variables bound by exists/forall anywhere inside a formula or effect."""
    found: set[str] = set()
    stack = [formula]
    while stack:
        node = stack.pop()
        if isinstance(node, _Exists | _ForAll | ForAllEffect):
            found.update(p.name for p in node.parameters)
        for value in getattr(node, "__dict__", {}).values():
            if isinstance(value, tuple):
                stack.extend(value)
            elif hasattr(value, "__dataclass_fields__"):
                stack.append(value)
    return found


def _cost_terms(effect: Effect) -> list[FunctionTerm]:
    terms: list[FunctionTerm] = []
    stack: list[object] = [effect]
    while stack:
        node = stack.pop()
        if isinstance(node, IncreaseCost) and isinstance(node.amount, FunctionTerm):
            terms.append(node.amount)
        for value in getattr(node, "__dict__", {}).values():
            if isinstance(value, tuple):
                stack.extend(value)
            elif hasattr(value, "__dataclass_fields__"):
                stack.append(value)
    return terms


def check_domain(domain: Domain) -> None:
    known = _known_types(domain)
    _check_types(domain.constants, known, domain.location)
    arities = {name: sig.arity for name, sig in domain.predicate_map().items()}
    function_arities = {sig.name: sig.arity for sig in domain.functions}
    constants = {c.name for c in domain.constants}
    for signature in (*domain.predicates, *domain.functions):
        _check_types(signature.parameters, known, signature.location)
    for action in domain.actions:
        _check_types(action.parameters, known, action.location)
        scope = {p.name for p in action.parameters}
        scope |= _quantified_variables(action.precondition) | _quantified_variables(action.effect)
        what = f"action {action.name!r}"
        for atom in formula_atoms(action.precondition):
            _check_atom(atom, arities, scope, constants, what)
        for atom, _ in effect_atoms(action.effect):
            _check_atom(atom, arities, scope, constants, what)
            if atom.predicate in domain.derived_predicates():
                raise InputError(f"derived predicate {atom.predicate!r} cannot be an effect",
                                 atom.location)
        for term in _cost_terms(action.effect):
            if term.name not in function_arities:
                raise InputError(f"unknown function {term.name!r} in {what}: declare it in "
                                 ":functions", term.location)
            if len(term.args) != function_arities[term.name]:
                raise InputError(
                    f"function {term.name!r} takes {function_arities[term.name]} argument(s), "
                    f"got {len(term.args)}", term.location)
            for arg in term.args:
                if is_variable(arg) and arg not in scope:
                    raise InputError(f"variable {arg} is not a parameter in {what}",
                                     term.location)
    for axiom in domain.axioms:
        if axiom.head.arity != arities[axiom.head.name]:
            # A head whose arity differs from the declaration (or from another axiom's head)
            # would ground facts of two lengths under one predicate.
            raise InputError(
                f"derived predicate {axiom.head.name!r} takes {arities[axiom.head.name]} "
                f"argument(s) where it is declared, got {axiom.head.arity} in its :derived head",
                axiom.head.location)
        for atom in formula_atoms(axiom.body):
            # Free body variables of a derived predicate are implicitly existential.
            _check_atom(atom, arities, None, constants, f"derived predicate {axiom.head.name!r}")
    _check_stratified(domain)


def _signed_atoms(formula: Formula, positive: bool = True) -> list[tuple[Atom, bool]]:
    """Atoms of ``formula`` with whether each occurs positively (``imply`` negates its
    condition; ``forall`` counts like ``not exists not``, so its body keeps its sign)."""
    match formula:
        case Atom():
            return [(formula, positive)]
        case Not(part):
            return _signed_atoms(part, not positive)
        case And(parts) | Or(parts):
            return [item for part in parts for item in _signed_atoms(part, positive)]
        case Imply(condition, consequence):
            return _signed_atoms(condition, not positive) + _signed_atoms(consequence, positive)
        case _Exists(_, body) | _ForAll(_, body):
            return _signed_atoms(body, positive)
    raise TypeError(f"not a formula: {formula!r}")


def _check_stratified(domain: Domain) -> None:
    """Derived predicates must not depend negatively on themselves through a cycle (no
    stratification, so no well-defined meaning): reported here rather than by the planner."""
    derived = domain.derived_predicates()
    edges: dict[str, set[str]] = {name: set() for name in derived}
    negative: list[tuple[str, Atom]] = []
    for axiom in domain.axioms:
        for atom, positive in _signed_atoms(axiom.body):
            if atom.predicate in derived:
                edges[axiom.head.name].add(atom.predicate)
                if not positive:
                    negative.append((axiom.head.name, atom))
    for head, atom in negative:
        # a negative edge head -> atom lies on a cycle iff head is reachable from atom
        reached, frontier = {atom.predicate}, [atom.predicate]
        while frontier:
            for successor in edges[frontier.pop()]:
                if successor not in reached:
                    reached.add(successor)
                    frontier.append(successor)
        if head in reached:
            raise InputError(
                f"derived predicate {head!r} depends on its own negation (through "
                f"{atom.predicate!r}): derived predicates must be stratified", atom.location)


def check_problem(problem: Problem, domain: Domain) -> None:
    known = _known_types(domain)
    _check_types(problem.objects, known, problem.location)
    if problem.domain_name and problem.domain_name != domain.name:
        raise InputError(
            f"problem is for domain {problem.domain_name!r} but the domain is {domain.name!r}",
            problem.location,
        )
    arities = {name: sig.arity for name, sig in domain.predicate_map().items()}
    names = {o.name for o in problem.objects} | {c.name for c in domain.constants}
    for atom in problem.init:
        _check_atom(atom, arities, set(), names, "the initial state")
        if atom.predicate in domain.derived_predicates():
            raise InputError(f"derived predicate {atom.predicate!r} cannot be an initial fact",
                             atom.location)
    scope = _quantified_variables(problem.goal)
    for atom in formula_atoms(problem.goal):
        _check_atom(atom, arities, scope, names, "the goal")


def check_streams(streams: StreamFile, domain: Domain) -> None:
    arities = {name: sig.arity for name, sig in domain.predicate_map().items()}
    constants = {c.name for c in domain.constants}
    for predicate in streams.predicates:
        arities.setdefault(predicate.name, len(predicate.head.args))
    seen: set[str] = set()
    for name, location in [*((s.name, s.location) for s in streams.streams),
                           *((f.name, f.location) for f in streams.functions),
                           *((p.name, p.location) for p in streams.predicates)]:
        if name in seen:
            raise InputError(f"{name!r} is declared twice in the stream file", location)
        seen.add(name)
    for stream in streams.streams:
        what = f"stream {stream.name!r}"
        _check_unique(stream.inputs, f"input of {what}", stream.location)
        _check_unique(stream.outputs, f"output of {what}", stream.location)
        overlap = set(stream.inputs) & set(stream.outputs)
        if overlap:
            raise InputError(f"{what} uses {sorted(overlap)[0]} as both input and output",
                             stream.location)
        for atom in (*stream.domain, *stream.fluent_domain):
            _check_atom(atom, arities, set(stream.inputs), constants, f"the :domain of {what}")
        _check_inputs_covered(stream.inputs, stream.domain, what, stream.location)
        for atom in stream.certified:
            _check_atom(atom, arities, set(stream.inputs) | set(stream.outputs), constants,
                        f"the :certified of {what}")
            if atom.predicate in domain.derived_predicates():
                raise InputError(f"{what} cannot certify derived predicate {atom.predicate!r}",
                                 atom.location)
        for fluent in stream.fluents:
            if fluent not in arities:
                raise InputError(f"unknown fluent predicate {fluent!r} in {what}",
                                 stream.location)
    function_arities = {sig.name: sig.arity for sig in domain.functions}
    for function in streams.functions:
        _check_unique(function.head.args, f"input of function {function.name!r}",
                      function.location)
        if function.name not in function_arities:
            raise InputError(f"function {function.name!r} is not declared in the domain's "
                             ":functions", function.location)
        if len(function.head.args) != function_arities[function.name]:
            raise InputError(f"function {function.name!r} takes "
                             f"{function_arities[function.name]} argument(s)", function.location)
        for atom in function.domain:
            _check_atom(atom, arities, set(function.head.args), constants,
                        f"the domain of function {function.name!r}")
        _check_inputs_covered(function.head.args, function.domain,
                              f"function {function.name!r}", function.location)
    for predicate in streams.predicates:
        _check_unique(predicate.head.args, f"input of predicate {predicate.name!r}",
                      predicate.location)
        if predicate.name in domain.derived_predicates():
            raise InputError(f"external predicate {predicate.name!r} is also derived",
                             predicate.location)
        for atom in predicate.domain:
            _check_atom(atom, arities, set(predicate.head.args), constants,
                        f"the domain of predicate {predicate.name!r}")
        _check_inputs_covered(predicate.head.args, predicate.domain,
                              f"predicate {predicate.name!r}", predicate.location)


def _check_unique(variables: Iterable[str], what: str, location: SourceLocation) -> None:
    """A stream's inputs (and its outputs) must be distinct variables, as in PDDLStream.

    ``:outputs (?p ?p)`` would bind one variable to two values (the first silently lost);
    ``:inputs (?b ?b)`` would call the procedure with one object twice.
    """
    seen: set[str] = set()
    for variable in variables:
        if variable in seen:
            raise InputError(f"{variable} is listed twice as an {what}", location)
        seen.add(variable)


def _check_inputs_covered(inputs: Iterable[str], domain_atoms: Iterable[Atom], what: str,
                          location: SourceLocation) -> None:
    """Every input must occur in a domain fact: the planner instantiates inputs from them."""
    covered = {arg for atom in domain_atoms for arg in atom.args}
    for variable in inputs:
        if is_variable(variable) and variable not in covered:
            raise InputError(f"input {variable} of {what} occurs in no fact of its :domain "
                             "(the planner finds inputs through those facts)", location)


def _stream_file_atoms(streams: StreamFile) -> list[Atom]:
    """Every atom written in a stream file (domains, certified facts, predicate heads)."""
    atoms: list[Atom] = []
    for stream in streams.streams:
        atoms.extend((*stream.domain, *stream.fluent_domain, *stream.certified))
    for function in streams.functions:
        atoms.extend(function.domain)
    for predicate in streams.predicates:
        atoms.extend((predicate.head, *predicate.domain))
    return atoms


def declare_predicates(domain: Domain, atoms: Iterable[Atom]) -> Domain:
    """``domain`` plus the predicates of ``atoms`` it does not declare (PDDLStream accepts
    predicates that appear only in stream files and ``init``); their arity is that of their
    first use and must be the same everywhere."""
    known = domain.predicate_map()
    added: dict[str, PredicateSignature] = {}
    for atom in atoms:
        if atom.predicate == EQUALITY or atom.predicate in known:
            continue
        first = added.get(atom.predicate)
        if first is None:
            parameters = tuple(TypedName(f"?x{i}") for i in range(len(atom.args)))
            added[atom.predicate] = PredicateSignature(atom.predicate, parameters,
                                                       atom.location)
        elif first.arity != len(atom.args):
            raise InputError(
                f"predicate {atom.predicate!r} takes {first.arity} argument(s) where it is "
                f"first used ({first.location}), got {len(atom.args)}", atom.location)
    if not added:
        return domain
    return replace(domain, predicates=(*domain.predicates, *added.values()))


def _declare_used_functions(domain: Domain, streams: StreamFile) -> Domain:
    """``domain`` plus the stream file's ``:function`` heads that an action's cost uses but
    ``:functions`` does not declare."""
    declared = {signature.name for signature in domain.functions}
    used = {term.name for action in domain.actions for term in _cost_terms(action.effect)}
    added = tuple(
        PredicateSignature(function.name,
                           tuple(TypedName(f"?x{i}") for i in range(len(function.head.args))),
                           function.location)
        for function in streams.functions
        if function.name in used and function.name not in declared)
    return replace(domain, functions=(*domain.functions, *added)) if added else domain


def fluent_predicates(domain: Domain) -> frozenset[str]:
    """Predicates whose facts actions change (any add or delete effect) and derived ones."""
    changed = {atom.predicate for action in domain.actions
               for atom, _ in effect_atoms(action.effect)}
    return frozenset(changed | domain.derived_predicates())


def _split_static(atoms: tuple[Atom, ...], fluent: frozenset[str]
                  ) -> tuple[tuple[Atom, ...], tuple[Atom, ...]]:
    """(atoms that enumerate the inputs, atoms of fluent predicates). Inputs are enumerated
    from the static atoms plus those fluent atoms needed to cover an input that no static
    atom mentions (matched against the facts known so far, as without this split)."""
    static = [a for a in atoms if a.predicate not in fluent]
    changing = tuple(a for a in atoms if a.predicate in fluent)
    covered = {arg for atom in static for arg in atom.args}
    for atom in changing:
        if any(is_variable(arg) and arg not in covered for arg in atom.args):
            static.append(atom)
            covered.update(atom.args)
    return tuple(static), changing


def prepare_streams(streams: StreamFile, domain: Domain) -> tuple[Domain, StreamFile]:
    """Read a stream file as PDDLStream does, then check the domain and the stream file.

    * predicates used only in the stream file (and ``init``) are declared in the domain,
      whose actions may use them;
    * ``:function`` declarations the domain does not declare in ``:functions`` are declared
      there when an action's cost uses them (PDDLStream's translator accepts that), and
      dropped otherwise (no action can use them; PDDLStream ignores them too);
    * :domain facts of predicates that actions change (PDDLStream's exogenous streams) go
      to ``Stream.fluent_domain``: what the stream certifies holds only in states where
      those facts hold. Inputs are enumerated from the other :domain facts (and from such a
      fact only where it alone mentions an input). In a ``:function`` or ``:predicate``
      domain such facts are dropped unless needed for an input (the actions that use the
      value check them).
    """
    domain = declare_predicates(domain, _stream_file_atoms(streams))
    domain = _declare_used_functions(domain, streams)
    check_domain(domain)
    fluent = fluent_predicates(domain)
    declared_functions = {signature.name for signature in domain.functions}
    prepared_streams = []
    for stream in streams.streams:
        static, changing = _split_static(stream.domain, fluent)
        prepared_streams.append(replace(stream, domain=static, fluent_domain=changing))
    functions = [replace(function, domain=_split_static(function.domain, fluent)[0])
                 for function in streams.functions if function.name in declared_functions]
    predicates = [replace(predicate, domain=_split_static(predicate.domain, fluent)[0])
                  for predicate in streams.predicates]
    prepared = replace(streams, streams=tuple(prepared_streams), functions=tuple(functions),
                       predicates=tuple(predicates))
    check_streams(prepared, domain)
    return domain, prepared
