"""An independent plan validator: replays a :class:`PlanResult` against its problem.

It shares nothing with the planner's search (no grounding, normalisation, task or heuristic):
only the syntax dataclasses of :mod:`.pddl.syntax`, the loaded :class:`PlanningProblem` and
the stream bindings. Semantics are closed-world: a fact holds only if it is an initial fact,
a fact certified by a legitimate stream result of the certificate, or added by the plan.

Checks, in order:

1. every stream result of ``result.certificate`` names a declared stream or external
   predicate, its ``:domain`` facts hold in the initial facts plus the certified facts of
   results accepted before it (no circular support), its certified facts are exactly the
   declaration's ``:certified`` instantiated, and tests / external predicates re-evaluated
   through their Python binding on the object values return true;
2. each plan step names a declared action with the right number and types of arguments,
   its precondition holds (lifted evaluation of ``and/or/not/imply/exists/forall/=`` with
   derived predicates evaluated on demand, stratified), then its effects are applied
   (conditional and universal effects evaluated in the state before the step; deletes
   before adds);
3. the goal holds in the final state; step and total costs match the recomputed ones
   (``:function`` costs come from the problem's numeric facts, else from re-running the
   ``:function`` binding once its domain facts are known).
"""

from __future__ import annotations

import itertools
import math
from collections import defaultdict
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ltamp_cli.planner.pddl.syntax import (
    EQUALITY,
    OBJECT_TYPE,
    Action,
    And,
    AndEffect,
    Atom,
    DerivedPredicate,
    Effect,
    Exists,
    ExternalPredicate,
    ForAll,
    ForAllEffect,
    Formula,
    FunctionTerm,
    Imply,
    IncreaseCost,
    Literal,
    Not,
    Number,
    Or,
    Stream,
    StreamFunction,
    TypedName,
    WhenEffect,
    is_variable,
)
from ltamp_cli.planner.problem import PlanningProblem
from ltamp_cli.planner.result import PlanResult, PlanStep, StreamResult

Fact = tuple[str, ...]  # (predicate, *object names)
Binding = dict[str, str]  # variable -> object name


@dataclass(frozen=True)
class ValidationReport:
    """Outcome of :func:`validate_plan`.

    ``errors`` are human-readable, one per problem found (``step N (action args): ...``);
    ``cost`` is the recomputed plan cost (``nan`` when it could not be computed);
    ``final_state`` the basic facts after the last step replayed.
    """

    valid: bool
    errors: tuple[str, ...]
    cost: float
    final_state: frozenset[Fact]

    def __bool__(self) -> bool:
        return self.valid


class _Invalid(Exception):
    """A fact of the problem that makes evaluation impossible (e.g. unknown object)."""


def validate_plan(problem: PlanningProblem, result: PlanResult,
                  streams: Mapping[str, Any] | None = None,
                  cost_tolerance: float = 1e-6,
                  check_stream_domains: bool = True) -> ValidationReport:
    """Check ``result`` (its plan, certificate and cost) against ``problem``.

    ``streams``: the mapping returned by the problem's ``make_streams``; built with a fixed
    seed from ``problem.streams_factory`` when not given (tests and predicates must not
    depend on it). ``cost_tolerance`` is relative. ``check_stream_domains=False`` accepts
    stream results whose ``:domain`` facts are not in the certificate (only for
    certificates known to list just the direct producers of the plan's facts); every other
    check still applies.
    """
    errors: list[str] = []
    if result.plan is None:
        return ValidationReport(False, (f"no plan (status {result.status!r})",), math.nan,
                                frozenset())
    try:
        context = _Context(problem, result, streams)
    except ValueError as error:
        return ValidationReport(False, (str(error),), math.nan, frozenset())
    known = context.check_certificate(result.certificate.stream_results, errors,
                                      check_stream_domains)
    context.static_facts = frozenset(known)
    state = _State(context, frozenset(known))
    total = 0.0
    for number, step in enumerate(result.plan, start=1):
        label = f"step {number} {step}"
        try:
            outcome = _apply_step(context, state, step, label, errors)
        except _Invalid as error:
            errors.append(f"{label}: {error}")
            outcome = None
        if outcome is None:
            errors.append(f"replay stopped at step {number}: the goal was not checked")
            return ValidationReport(False, tuple(errors), math.nan, state.facts)
        state, step_cost = outcome
        if not _close(step.cost, step_cost, cost_tolerance):
            errors.append(f"{label}: reported cost {step.cost:g} but the action costs "
                          f"{step_cost:g}")
        total += step_cost
    try:
        goal_holds = state.holds(problem.goal, {})
    except _Invalid as error:
        errors.append(f"goal: {error}")
        goal_holds = True
    if not goal_holds:
        failing = [str_formula(part) for part in _conjuncts(problem.goal)
                   if not state.holds(part, {})]
        errors.append("goal: does not hold after the last step; failing: "
                      + "; ".join(failing))
    if not _close(result.cost, total, cost_tolerance):
        errors.append(f"plan cost: reported {result.cost:g} but the actions cost {total:g}")
    context.check_preimage(result.certificate.preimage, errors)
    return ValidationReport(not errors, tuple(errors), total, state.facts)


def _close(reported: float, actual: float, tolerance: float) -> bool:
    return abs(reported - actual) <= tolerance * max(1.0, abs(actual))


class _Context:
    """What does not change along the plan: declarations, objects, types, bindings."""

    def __init__(self, problem: PlanningProblem, result: PlanResult,
                 streams: Mapping[str, Any] | None) -> None:
        self.problem = problem
        domain = problem.domain
        self.actions: dict[str, Action] = {a.name: a for a in domain.actions}
        self.axioms: dict[str, list[DerivedPredicate]] = defaultdict(list)
        for axiom in domain.axioms:
            self.axioms[axiom.head.name].append(axiom)
        self.parents = domain.type_parents()
        self.streams: dict[str, Stream] = {}
        self.stream_functions: dict[str, StreamFunction] = {}
        self.external_predicates: dict[str, ExternalPredicate] = {}
        if problem.stream_file is not None:
            self.streams = {s.name: s for s in problem.stream_file.streams}
            self.stream_functions = {f.name: f for f in problem.stream_file.functions}
            self.external_predicates = {p.name: p for p in problem.stream_file.predicates}
        self._streams_given = streams
        # keyed by lower-cased name: PDDL names, and so binding keys, are case-insensitive
        self._bindings: Mapping[str, Any] | None = (
            None if streams is None else {str(k).lower(): v for k, v in streams.items()})
        # Object universe: the problem's objects (typed) and every object the run created.
        self.types: dict[str, str] = {name: t for name, (t, _) in problem.objects.items()}
        for name in result.objects:
            self.types.setdefault(name, OBJECT_TYPE)
        self.values: dict[str, Any] = {name: (name if value is None else value)
                                       for name, (_, value) in problem.objects.items()}
        self.values.update(result.objects)
        self._by_type: dict[str, tuple[str, ...]] = {}
        self.initial_functions: dict[Fact, float] = {
            (v.term.name, *v.term.args): v.value for v in problem.function_values}
        self._function_cache: dict[Fact, float] = {}
        self._external_cache: dict[Fact, bool] = {}
        self.static_facts: frozenset[Fact] = frozenset()
        self.recursive = _recursive_derived(domain.axioms)
        self._free_cache: dict[int, frozenset[str]] = {}

    # --- objects and types -------------------------------------------------------------
    def is_subtype(self, type_name: str, ancestor: str) -> bool:
        if ancestor == OBJECT_TYPE:
            return True
        seen: set[str] = set()
        while type_name not in seen:
            if type_name == ancestor:
                return True
            seen.add(type_name)
            type_name = self.parents.get(type_name, OBJECT_TYPE)
        return False

    def objects_of(self, type_name: str) -> tuple[str, ...]:
        found = self._by_type.get(type_name)
        if found is None:
            found = tuple(sorted(n for n, t in self.types.items()
                                 if self.is_subtype(t, type_name)))
            self._by_type[type_name] = found
        return found

    def has_type(self, name: str, type_name: str) -> bool:
        return name in self.types and self.is_subtype(self.types[name], type_name)

    def free_variables(self, formula: Formula) -> frozenset[str]:
        key = id(formula)
        found = self._free_cache.get(key)
        if found is None:
            found = _free_variables(formula)
            self._free_cache[key] = found
        return found

    # --- Python bindings ---------------------------------------------------------------
    def binding(self, name: str) -> Callable[..., Any]:
        external = self.streams.get(name) or self.external_predicates.get(name)
        if external is not None and external.negates:  # a negated test (pddl/negation.py)
            test = self.binding(external.negates)
            return lambda *args: not test(*args)
        if self._bindings is None:
            factory = self.problem.streams_factory
            if factory is None:
                raise _Invalid(f"{name!r} needs a Python binding but the problem has none")
            made = factory(dict(self.problem.world), np.random.default_rng(0))
            self._bindings = {str(k).lower(): v for k, v in made.items()}
        provided = self._bindings.get(name) if self._bindings is not None else None
        if provided is None:
            raise _Invalid(f"no Python binding for {name!r}")
        function = getattr(provided, "function", provided)
        if not callable(function):
            raise _Invalid(f"the binding of {name!r} is not callable")
        return function

    def call(self, name: str, args: Sequence[str]) -> Any:
        function = self.binding(name)
        try:
            return function(*(self.values.get(a, a) for a in args))
        except Exception as error:
            raise _Invalid(f"{name}({', '.join(args)}) raised "
                           f"{type(error).__name__}: {error}") from None

    def external_holds(self, fact: Fact) -> bool:
        """An external predicate: its domain facts are known and its binding says true."""
        cached = self._external_cache.get(fact)
        if cached is None:
            predicate = self.external_predicates[fact[0]]
            mapping = dict(zip(predicate.head.args, fact[1:], strict=True))
            cached = all(_ground(atom, mapping) in self.static_facts
                         for atom in predicate.domain) and bool(self.call(fact[0], fact[1:]))
            self._external_cache[fact] = cached
        return cached

    def function_value(self, term: Fact) -> float:
        if term in self.initial_functions:
            return self.initial_functions[term]
        cached = self._function_cache.get(term)
        if cached is not None:
            return cached
        function = self.stream_functions.get(term[0])
        if function is None:
            raise _Invalid(f"cost term ({' '.join(term)}) has no value: no numeric fact and "
                           "no :function stream")
        mapping = dict(zip(function.head.args, term[1:], strict=True))
        missing = [_ground(atom, mapping) for atom in function.domain
                   if _ground(atom, mapping) not in self.static_facts]
        if missing:
            raise _Invalid(f"cost term ({' '.join(term)}) is undefined: its domain fact "
                           f"{_str_fact(missing[0])} is not known")
        value = float(self.call(term[0], term[1:]))
        self._function_cache[term] = value
        return value

    # --- certificate -------------------------------------------------------------------
    def check_certificate(self, results: Sequence[StreamResult], errors: list[str],
                          check_domains: bool = True) -> set[Fact]:
        """Initial facts plus the certified facts of every legitimate stream result."""
        known: set[Fact] = {(a.predicate, *a.args) for a in self.problem.init}
        pending: list[tuple[StreamResult, list[Fact]]] = []
        for result in results:
            label = f"stream result {result.stream}({' '.join(result.inputs)})"
            if result.outputs:
                label += f" -> ({' '.join(result.outputs)})"
            try:
                domain = self._check_stream_result(result)
            except _Invalid as error:
                errors.append(f"{label}: {error}")
                continue
            pending.append((result, domain))
        # Accept results whose domain holds, until a fixpoint: support must be well-founded.
        progress = True
        while pending and progress:
            progress = False
            waiting = []
            for result, domain in pending:
                if all(fact in known for fact in domain):
                    known.update(tuple(fact) for fact in result.certified)
                    progress = True
                else:
                    waiting.append((result, domain))
            pending = waiting
        for result, domain in pending:
            if not check_domains:
                known.update(tuple(fact) for fact in result.certified)
                continue
            missing = next(fact for fact in domain if fact not in known)
            errors.append(f"stream result {result.stream}({' '.join(result.inputs)}): "
                          f"domain fact {_str_fact(missing)} is neither initial nor certified")
        return known

    def _check_stream_result(self, result: StreamResult) -> list[Fact]:
        """Shape checks and re-evaluation; returns the instantiated domain facts."""
        stream = self.streams.get(result.stream)
        predicate = self.external_predicates.get(result.stream)
        if stream is None and predicate is None:
            raise _Invalid("no such stream or external predicate in the stream file")
        inputs = stream.inputs if stream is not None else predicate.head.args  # type: ignore[union-attr]
        outputs = stream.outputs if stream is not None and not result.wild else ()
        if len(result.inputs) != len(inputs):
            raise _Invalid(f"expected {len(inputs)} input(s), got {len(result.inputs)}")
        if len(result.outputs) != len(outputs):
            raise _Invalid(f"expected {len(outputs)} output(s), got {len(result.outputs)}")
        for name in (*result.inputs, *result.outputs):
            if name not in self.types:
                raise _Invalid(f"unknown object {name!r}")
        mapping = dict(zip(inputs, result.inputs, strict=True))
        mapping.update(zip(outputs, result.outputs, strict=True))
        if stream is not None:
            declared = stream.certified
            domain = stream.domain
        else:
            assert predicate is not None
            declared = (predicate.head,)
            domain = predicate.domain
        if result.wild:  # only the call knows what it certified; its inputs must be valid
            return [_ground(atom, mapping) for atom in domain]
        expected = {_ground(atom, mapping) for atom in declared}
        certified = {tuple(fact) for fact in result.certified}
        if certified != expected:
            extra = sorted(certified - expected)
            absent = sorted(expected - certified)
            detail = (f"certifies {_str_fact(extra[0])} which is not declared" if extra
                      else f"does not certify {_str_fact(absent[0])}")
            raise _Invalid(detail)
        if stream is not None and stream.is_rule:
            return [_ground(atom, mapping) for atom in domain]  # a rule is always true
        if (stream is None or stream.is_test) and not self.call(result.stream, result.inputs):
            raise _Invalid("its Python binding returns false on these values")
        return [_ground(atom, mapping) for atom in domain]

    def check_preimage(self, preimage: Sequence[Fact], errors: list[str]) -> None:
        """Facts of static predicates in the preimage must be initial or certified."""
        changing = {atom.predicate for action in self.actions.values()
                    for atom, _ in _effect_literals(action.effect)}
        declared = set(self.problem.domain.predicate_map()) | set(self.external_predicates)
        derived = set(self.axioms)
        for fact in preimage:
            head = fact[0]
            if head in changing or head in derived or head not in declared:
                continue  # fluents, derived facts and cost terms are checked by the replay
            if head in self.external_predicates:
                continue
            if tuple(fact) not in self.static_facts:
                errors.append(f"preimage: static fact {_str_fact(tuple(fact))} is neither "
                              "initial nor certified")


class _State:
    """One state of the replay: basic facts, with derived facts evaluated on demand."""

    def __init__(self, context: _Context, facts: frozenset[Fact]) -> None:
        self.context = context
        self.facts = facts
        self._by_predicate: dict[str, list[tuple[str, ...]]] = defaultdict(list)
        for fact in facts:
            self._by_predicate[fact[0]].append(fact[1:])
        self._derived: dict[Fact, bool] = {}
        self._extensions: dict[str, set[tuple[str, ...]]] = {}
        self._in_progress: set[str] = set()

    # --- atoms -------------------------------------------------------------------------
    def atom_holds(self, fact: Fact) -> bool:
        predicate = fact[0]
        if predicate == EQUALITY:
            return fact[1] == fact[2]
        if predicate in self.context.axioms:
            return self._derived_holds(fact)
        if predicate in self.context.external_predicates:
            return fact in self.context.static_facts or self.context.external_holds(fact)
        return fact in self.facts

    def tuples(self, predicate: str) -> Sequence[tuple[str, ...]]:
        """Every true argument tuple of a basic or derived predicate."""
        if predicate in self.context.axioms:
            return tuple(self._extension(predicate))
        return self._by_predicate.get(predicate, ())

    def _derived_holds(self, fact: Fact) -> bool:
        predicate = fact[0]
        if predicate in self.context.recursive or predicate in self._in_progress:
            return fact[1:] in self._extension(predicate)
        cached = self._derived.get(fact)
        if cached is None:
            cached = False
            for axiom in self.context.axioms[predicate]:
                binding = _match_head(axiom, fact[1:], self.context)
                if binding is None:
                    continue
                extra = self._existential(axiom, binding)
                if next(self.solutions(_conjuncts(axiom.body), binding, extra), None) is not None:
                    cached = True
                    break
            self._derived[fact] = cached
        return cached

    def _existential(self, axiom: DerivedPredicate, bound: Mapping[str, str]
                     ) -> tuple[TypedName, ...]:
        head = {p.name for p in axiom.head.parameters}
        free = sorted(self.context.free_variables(axiom.body) - head - set(bound))
        return tuple(TypedName(v) for v in free)

    def _extension(self, predicate: str) -> set[tuple[str, ...]]:
        """All true tuples of a derived predicate (its whole recursive group, bottom-up)."""
        found = self._extensions.get(predicate)
        if found is not None:
            return found
        group = self.context.recursive.get(predicate, frozenset({predicate}))
        for member in group:
            self._extensions[member] = set()
            self._in_progress.add(member)
        changed = True
        while changed:
            changed = False
            for member in sorted(group):
                for axiom in self.context.axioms[member]:
                    head = axiom.head.parameters
                    variables = (*head, *self._existential(axiom, {}))
                    for binding in list(self.solutions(_conjuncts(axiom.body), {}, variables)):
                        row = tuple(binding[p.name] for p in head)
                        if row not in self._extensions[member]:
                            self._extensions[member].add(row)
                            changed = True
            if len(group) == 1 and predicate not in self.context.recursive:
                break  # not recursive: one pass is the fixpoint
        self._in_progress.difference_update(group)
        return self._extensions[predicate]

    # --- formulas ----------------------------------------------------------------------
    def holds(self, formula: Formula, binding: Mapping[str, str]) -> bool:
        match formula:
            case Atom(predicate, args):
                return self.atom_holds((predicate, *(_substitute(a, binding) for a in args)))
            case Not(part):
                return not self.holds(part, binding)
            case And(parts):
                return all(self.holds(part, binding) for part in parts)
            case Or(parts):
                return any(self.holds(part, binding) for part in parts)
            case Imply(condition, consequence):
                return not self.holds(condition, binding) or self.holds(consequence, binding)
            case Exists(parameters, body):
                inner = {k: v for k, v in binding.items()
                         if k not in {p.name for p in parameters}}
                return next(self.solutions(_conjuncts(body), inner, parameters),
                            None) is not None
            case ForAll(parameters, body):
                inner = {k: v for k, v in binding.items()
                         if k not in {p.name for p in parameters}}
                # forall x. body  ==  not exists x. not body
                return next(self.solutions(_negated_conjuncts(body), inner, parameters),
                            None) is None
        raise TypeError(f"not a formula: {formula!r}")

    def solutions(self, conjuncts: Sequence[Formula], binding: Mapping[str, str],
                  variables: Sequence[TypedName]) -> Iterator[Binding]:
        """Bindings of ``variables`` (extending ``binding``) making every conjunct true.

        Positive atoms bind variables by matching true facts (basic ones first); equality
        binds by copying; variables bound by nothing range over the objects of their type.
        """
        unbound = {p.name: p.type for p in variables if p.name not in binding}
        if not unbound:
            if all(self.holds(c, binding) for c in conjuncts):
                yield dict(binding)
            return
        pending = []
        for conjunct in conjuncts:
            if self.context.free_variables(conjunct) & unbound.keys():
                pending.append(conjunct)
            elif not self.holds(conjunct, binding):
                return
        generator = self._choose_generator(pending, binding, unbound)
        if generator is None:
            name = min(unbound)
            rest = [TypedName(v, t) for v, t in unbound.items() if v != name]
            for value in self.context.objects_of(unbound[name]):
                yield from self.solutions(pending, {**binding, name: value}, rest)
            return
        atom, rows = generator
        others = [c for c in pending if c is not atom]
        for row in rows:
            extended = _unify(atom, row, binding)
            if extended is None:
                continue
            if not all(self.context.has_type(extended[v], t)
                       for v, t in unbound.items() if v in extended):
                continue
            rest = [TypedName(v, t) for v, t in unbound.items() if v not in extended]
            yield from self.solutions(others, extended, rest)

    def _choose_generator(self, pending: Sequence[Formula], binding: Mapping[str, str],
                          unbound: Mapping[str, str]
                          ) -> tuple[Atom, Sequence[tuple[str, ...]]] | None:
        best: tuple[int, int, Atom, Sequence[tuple[str, ...]]] | None = None
        for conjunct in pending:
            if not isinstance(conjunct, Atom):
                continue
            predicate = conjunct.predicate
            if predicate == EQUALITY:
                left, right = (_substitute(a, binding) for a in conjunct.args)
                if is_variable(left) != is_variable(right):
                    value = right if is_variable(left) else left
                    return conjunct, [(value, value)]
                continue
            if predicate in self.context.external_predicates:
                continue
            derived = predicate in self.context.axioms
            if derived and predicate in self._in_progress and \
                    predicate not in self.context.recursive:
                continue
            rank = 1 if derived else 0
            if best is not None and rank > best[0]:
                continue
            rows = self.tuples(predicate)
            if best is None or (rank, len(rows)) < (best[0], best[1]):
                best = (rank, len(rows), conjunct, rows)
        return None if best is None else (best[2], best[3])


def _apply_step(context: _Context, state: _State, step: PlanStep, label: str,
                errors: list[str]) -> tuple[_State, float] | None:
    """The next state and the step's cost, or ``None`` (errors appended) if not applicable."""
    action = context.actions.get(step.name)
    if action is None:
        errors.append(f"{label}: no action {step.name!r} in the domain")
        return None
    if len(step.args) != len(action.parameters):
        errors.append(f"{label}: {step.name!r} takes {len(action.parameters)} argument(s), "
                      f"got {len(step.args)}")
        return None
    binding: Binding = {}
    for parameter, arg in zip(action.parameters, step.args, strict=True):
        if arg not in context.types:
            errors.append(f"{label}: unknown object {arg!r} for {parameter.name}")
            return None
        if not context.has_type(arg, parameter.type):
            errors.append(f"{label}: {arg!r} is not of type {parameter.type!r} "
                          f"({parameter.name})")
            return None
        binding[parameter.name] = arg
    if len(step.values) == len(step.args):
        for arg, value in zip(step.args, step.values, strict=True):
            if not _same_value(value, context.values.get(arg, arg)):
                errors.append(f"{label}: the value given for {arg!r} is not the object's value")
    if not state.holds(action.precondition, binding):
        failing = [str_formula(part, binding) for part in _conjuncts(action.precondition)
                   if not state.holds(part, binding)]
        errors.append(f"{label}: precondition does not hold; failing: " + "; ".join(failing))
        return None
    adds: set[Fact] = set()
    deletes: set[Fact] = set()
    costs: list[float] = []
    _collect_effects(action.effect, binding, state, adds, deletes, costs)
    facts = (state.facts - deletes) | adds
    return _State(context, frozenset(facts)), float(sum(costs))


def _collect_effects(effect: Effect, binding: Mapping[str, str], state: _State,
                     adds: set[Fact], deletes: set[Fact], costs: list[float]) -> None:
    match effect:
        case Literal(atom, positive):
            fact = (atom.predicate, *(_substitute(a, binding) for a in atom.args))
            if any(is_variable(a) for a in fact[1:]):
                raise _Invalid(f"effect {_str_fact(fact)} has an unbound variable")
            (adds if positive else deletes).add(fact)
        case AndEffect(parts):
            for part in parts:
                _collect_effects(part, binding, state, adds, deletes, costs)
        case ForAllEffect(parameters, inner):
            names = {p.name for p in parameters}
            outer = {k: v for k, v in binding.items() if k not in names}
            if isinstance(inner, WhenEffect):
                # Only the instances whose condition holds matter: let it bind the variables.
                for extended in list(state.solutions(_conjuncts(inner.condition), outer,
                                                     parameters)):
                    _collect_effects(inner.effect, extended, state, adds, deletes, costs)
                return
            domains = [state.context.objects_of(p.type) for p in parameters]
            for values in itertools.product(*domains):
                extended = {**outer, **{p.name: v for p, v in
                                        zip(parameters, values, strict=True)}}
                _collect_effects(inner, extended, state, adds, deletes, costs)
        case WhenEffect(condition, inner):
            if state.holds(condition, binding):
                _collect_effects(inner, binding, state, adds, deletes, costs)
        case IncreaseCost(amount):
            if isinstance(amount, Number):
                costs.append(amount.value)
            else:
                assert isinstance(amount, FunctionTerm)
                term = (amount.name, *(_substitute(a, binding) for a in amount.args))
                costs.append(state.context.function_value(term))
        case _:
            raise TypeError(f"not an effect: {effect!r}")


# --- helpers ---------------------------------------------------------------------------------
def _substitute(arg: str, binding: Mapping[str, str]) -> str:
    return binding.get(arg, arg) if is_variable(arg) else arg


def _ground(atom: Atom, mapping: Mapping[str, str]) -> Fact:
    return (atom.predicate, *(mapping.get(a, a) for a in atom.args))


def _unify(atom: Atom, row: tuple[str, ...], binding: Mapping[str, str]) -> Binding | None:
    if len(row) != len(atom.args):
        return None
    extended = dict(binding)
    for arg, value in zip(atom.args, row, strict=True):
        if is_variable(arg):
            bound = extended.get(arg)
            if bound is None:
                extended[arg] = value
            elif bound != value:
                return None
        elif arg != value:
            return None
    return extended


def _match_head(axiom: DerivedPredicate, args: tuple[str, ...], context: _Context
                ) -> Binding | None:
    parameters = axiom.head.parameters
    if len(parameters) != len(args):
        return None
    binding: Binding = {}
    for parameter, value in zip(parameters, args, strict=True):
        if binding.get(parameter.name, value) != value:
            return None
        if not context.has_type(value, parameter.type):
            return None
        binding[parameter.name] = value
    return binding


def _conjuncts(formula: Formula) -> list[Formula]:
    if isinstance(formula, And):
        return [part for inner in formula.parts for part in _conjuncts(inner)]
    return [formula]


def _negate(formula: Formula) -> Formula:
    return formula.part if isinstance(formula, Not) else Not(formula)


def _negated_conjuncts(formula: Formula) -> list[Formula]:
    """Conjuncts equivalent to ``(not formula)``, exposing atoms that can bind variables."""
    if isinstance(formula, Imply):
        return [*_conjuncts(formula.condition), _negate(formula.consequence)]
    if isinstance(formula, Or):
        return [_negate(part) for part in formula.parts]
    if isinstance(formula, Not):
        return _conjuncts(formula.part)
    return [Not(formula)]


def _free_variables(formula: Formula) -> frozenset[str]:
    match formula:
        case Atom(_, args):
            return frozenset(a for a in args if is_variable(a))
        case Not(part):
            return _free_variables(part)
        case And(parts) | Or(parts):
            return frozenset().union(*(_free_variables(p) for p in parts))
        case Imply(condition, consequence):
            return _free_variables(condition) | _free_variables(consequence)
        case Exists(parameters, body) | ForAll(parameters, body):
            return _free_variables(body) - {p.name for p in parameters}
    raise TypeError(f"not a formula: {formula!r}")


def _effect_literals(effect: Effect) -> list[tuple[Atom, bool]]:
    match effect:
        case Literal(atom, positive):
            return [(atom, positive)]
        case AndEffect(parts):
            return [item for part in parts for item in _effect_literals(part)]
        case ForAllEffect(_, inner) | WhenEffect(_, inner):
            return _effect_literals(inner)
    return []


def _dependencies(formula: Formula, negated: bool = False) -> Iterator[tuple[str, bool]]:
    """(predicate, occurs negatively) for every atom of a formula."""
    match formula:
        case Atom(predicate, _):
            yield predicate, negated
        case Not(part):
            yield from _dependencies(part, not negated)
        case And(parts) | Or(parts):
            for part in parts:
                yield from _dependencies(part, negated)
        case Imply(condition, consequence):
            yield from _dependencies(condition, not negated)
            yield from _dependencies(consequence, negated)
        case Exists(_, body):
            yield from _dependencies(body, negated)
        case ForAll(_, body):
            # forall = not exists not: the body is read both ways.
            yield from _dependencies(body, negated)
            yield from _dependencies(body, not negated)


def _recursive_derived(axioms: Sequence[DerivedPredicate]) -> dict[str, frozenset[str]]:
    """Derived predicates in a dependency cycle, mapped to their cycle's group.

    Raises ``ValueError`` when a cycle goes through negation (the
    axioms are not stratified; the domain checker should have refused it).
    """
    derived = {axiom.head.name for axiom in axioms}
    edges: dict[str, set[tuple[str, bool]]] = defaultdict(set)
    for axiom in axioms:
        for predicate, negative in _dependencies(axiom.body):
            if predicate in derived:
                edges[axiom.head.name].add((predicate, negative))

    def reachable(start: str) -> set[str]:
        seen: set[str] = set()
        stack = [target for target, _ in edges[start]]
        while stack:
            node = stack.pop()
            if node not in seen:
                seen.add(node)
                stack.extend(target for target, _ in edges[node])
        return seen

    reach = {name: reachable(name) for name in derived}
    groups: dict[str, frozenset[str]] = {}
    for name in derived:
        if name in reach[name]:
            group = frozenset(other for other in reach[name] if name in reach[other])
            for target, negative in edges[name]:
                if negative and target in group:
                    raise ValueError(f"derived predicate {name!r} depends negatively on "
                                     f"{target!r} in a cycle: the axioms are not stratified")
            groups[name] = group
    return groups


def _same_value(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return bool(np.array_equal(np.asarray(a), np.asarray(b)))
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(_same_value(x, y) for x, y in zip(a, b, strict=True))
    try:
        return bool(a == b)
    except Exception:
        return a is b


def _str_fact(fact: Sequence[str]) -> str:
    return "(" + " ".join(fact) + ")"


def str_formula(formula: Formula, binding: Mapping[str, str] | None = None) -> str:
    """PDDL text of a formula with ``binding`` substituted (for error messages)."""
    binding = binding or {}
    match formula:
        case Atom(predicate, args):
            return _str_fact((predicate, *(_substitute(a, binding) for a in args)))
        case Not(part):
            return f"(not {str_formula(part, binding)})"
        case And(parts) | Or(parts):
            word = "and" if isinstance(formula, And) else "or"
            return "(" + " ".join((word, *(str_formula(p, binding) for p in parts))) + ")"
        case Imply(condition, consequence):
            return f"(imply {str_formula(condition, binding)} {str_formula(consequence, binding)})"
        case Exists(parameters, body) | ForAll(parameters, body):
            word = "exists" if isinstance(formula, Exists) else "forall"
            names = " ".join(p.name if p.type == OBJECT_TYPE else f"{p.name} - {p.type}"
                             for p in parameters)
            inner = {k: v for k, v in binding.items() if k not in {p.name for p in parameters}}
            return f"({word} ({names}) {str_formula(body, inner)})"
    return repr(formula)


__all__ = ["ValidationReport", "str_formula", "validate_plan"]
