"""From a PDDLStream :class:`~.language.PDDLProblem` (texts, Python values and procedures)
to the planner's checked :class:`~ltamp_cli.planner.problem.PlanningProblem`.

Objects are arbitrary Python values, hashable or not (numpy arrays compare by content, other
unhashable values by identity). A string that is a valid PDDL name becomes the object of that
(lower-cased) name; any other value gets a generated ``@o{n}`` name.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream.generator import FunctionInfo, StreamInfo, fn_from_constant
from ltamp_cli.pddlstream.language import DEBUG, SHARED_DEBUG, PartialInputs, PDDLProblem
from ltamp_cli.planner.objects import ObjectTable
from ltamp_cli.planner.pddl import syntax
from ltamp_cli.planner.pddl.check import (
    check_domain,
    check_problem,
    declare_predicates,
    prepare_streams,
)
from ltamp_cli.planner.pddl.parse import parse_domain, parse_stream_file
from ltamp_cli.planner.pddl.syntax import (
    Atom,
    FunctionTerm,
    FunctionValue,
    StreamFile,
    StreamFunction,
    TypedName,
)
from ltamp_cli.planner.problem import PlanningProblem, with_negated_tests
from ltamp_cli.planner.streams import FINITE_ITERATORS, Binding, External, Stream, WildOutput
from ltamp_cli.planner.streams import PartialInputs as PlannerPartialInputs
from ltamp_cli.planner.streams import StreamInfo as PlannerStreamInfo

Info = StreamInfo | FunctionInfo
_CONNECTIVES = {"and": syntax.And, "or": syntax.Or}
_QUANTIFIERS = {"exists": syntax.Exists, "forall": syntax.ForAll}


def _label(text: Any, default: str) -> str:
    """The file a PDDL text was read from (:func:`.language.read`), else ``default``."""
    return str(getattr(text, "path", default))


class ObjectNames:
    """PDDL names for the Python values of one problem, in a planner :class:`ObjectTable`."""

    def __init__(self) -> None:
        self.table = ObjectTable()
        self.types: dict[str, str] = {}
        #: Domain constants that ``constant_map`` gives no value (their value is their name):
        #: a string naming one, in any case, is that constant.
        self._unmapped: set[str] = set()

    def add_constant(self, name: str, value: Any, type_name: str, mapped: bool = True) -> None:
        self.table.add(name, value)
        self.types[name] = type_name
        if not mapped:
            self._unmapped.add(name)

    def name(self, value: Any) -> str:
        """The object of ``value``, created on first use."""
        if isinstance(value, str) and _is_pddl_name(value):
            lowered = value.lower()
            if lowered not in self.table:
                self.table.add(lowered, value)
                self.types[lowered] = syntax.OBJECT_TYPE
                return lowered
            if self.table.value(lowered) is value or self.table.value(lowered) == value:
                return lowered
            if lowered in self._unmapped:  # (:constants V1) and "V1" in init: one object
                return lowered
        name = self.table.intern(value, "o")
        self.types.setdefault(name, syntax.OBJECT_TYPE)
        return name


def _is_pddl_name(text: str) -> bool:
    return bool(text) and not text.startswith(("?", ":", "@", "#", "-")) and not any(
        c.isspace() or c in "();" for c in text)


def _term(item: Any, names: ObjectNames, variables: bool) -> str:
    if variables and isinstance(item, str) and item.startswith("?"):
        return item.lower()
    return names.name(item)


def _fact_head(fact: Any, what: str) -> str:
    if not isinstance(fact, tuple | list) or not fact or not isinstance(fact[0], str):
        raise InputError(f"{what}: expected a tuple (predicate, value, ...), got {fact!r:.80}")
    return fact[0].lower()


def to_atom(fact: Any, names: ObjectNames, what: str, variables: bool = False) -> Atom:
    """A fact ``(predicate, value, ...)`` as an atom over object names."""
    head = _fact_head(fact, what)
    return Atom(head, tuple(_term(item, names, variables) for item in fact[1:]))


def to_formula(formula: Any, names: ObjectNames, what: str = "the goal") -> syntax.Formula:
    """A PDDLStream formula (nested tuples, see :mod:`.language`) as planner syntax."""
    head = _fact_head(formula, what)
    parts = formula[1:]
    if head in _CONNECTIVES:
        return _CONNECTIVES[head](tuple(to_formula(p, names, what) for p in parts))
    if head == "not" and len(parts) == 1:
        return syntax.Not(to_formula(parts[0], names, what))
    if head == "imply" and len(parts) == 2:
        return syntax.Imply(to_formula(parts[0], names, what), to_formula(parts[1], names, what))
    if head in _QUANTIFIERS and len(parts) == 2:
        parameters = parts[0]
        if isinstance(parameters, str) or not all(
                isinstance(p, str) and p.startswith("?") for p in parameters):
            raise InputError(f"{what}: {head} takes a list of '?variables', got {parameters!r}")
        typed = tuple(TypedName(p.lower()) for p in parameters)
        return _QUANTIFIERS[head](typed, to_formula(parts[1], names, what))
    if head in ("not", "imply", *_QUANTIFIERS):
        raise InputError(f"{what}: wrong number of arguments in {formula!r:.80}")
    return to_atom(formula, names, what, variables=True)


def _stream_file(stream_pddl: Any) -> StreamFile | None:
    """One stream file from ``None``, a text or a list of texts (rules renumbered)."""
    if stream_pddl is None:
        return None
    if isinstance(stream_pddl, str):
        texts = [stream_pddl]
    elif isinstance(stream_pddl, list | tuple) and all(isinstance(t, str) for t in stream_pddl):
        texts = list(stream_pddl)
    else:
        raise InputError(f"stream_pddl: expected None, a PDDL text or a list of texts, got "
                         f"{stream_pddl!r:.60}")
    files = [parse_stream_file(text, _label(text, "stream.pddl")) for text in texts]
    if not files:
        return None
    rules = [s for f in files for s in f.streams if s.is_rule]
    renamed = {id(rule): replace(rule, name=f":rule{i}") for i, rule in enumerate(rules)}
    streams = tuple(renamed.get(id(s), s) for f in files for s in f.streams)
    return StreamFile(files[0].name, streams, tuple(x for f in files for x in f.functions),
                      tuple(x for f in files for x in f.predicates), files[0].location)


def _init(init: Iterable[Any], names: ObjectNames) -> tuple[list[Atom], list[FunctionValue]]:
    atoms: list[Atom] = []
    values: list[FunctionValue] = []
    for index, fact in enumerate(init):
        what = f"init[{index}]"
        head = _fact_head(fact, what)
        if head == syntax.EQUALITY and len(fact) == 3 and isinstance(fact[1], tuple | list):
            term = to_atom(fact[1], names, what)
            try:
                number = float(fact[2])
            except (TypeError, ValueError):
                raise InputError(f"{what}: expected ('=', (function, ...), number), got "
                                 f"{fact!r:.80}") from None
            values.append(FunctionValue(FunctionTerm(term.predicate, term.args), number))
        else:
            atoms.append(to_atom(fact, names, what))
    return atoms, values


def _lowered(mapping: Mapping[str, Any] | None, what: str) -> dict[str, Any]:
    lowered: dict[str, Any] = {}
    for key, value in (mapping or {}).items():
        if not isinstance(key, str):
            raise InputError(f"{what}: keys must be stream names, got {key!r}")
        if key.lower() in lowered:
            raise InputError(f"{what} names {key!r} twice (names are case-insensitive)")
        lowered[key.lower()] = value
    return lowered


def to_planning_problem(problem: PDDLProblem, stream_info: Mapping[str, Info] | None = None
                        ) -> PlanningProblem:
    """Parse and check a PDDLStream problem; bad input raises one-line ``InputError``s."""
    if not isinstance(problem, tuple) or len(problem) != 6:
        raise InputError("expected PDDLProblem(domain_pddl, constant_map, stream_pddl, "
                         "stream_map, init, goal)")
    domain_pddl, constant_map, stream_pddl, stream_map, init, goal = problem
    if not isinstance(domain_pddl, str):
        raise InputError(f"domain_pddl: expected a PDDL text (str, e.g. from read(path)), got "
                         f"{domain_pddl!r:.60}")
    domain = parse_domain(domain_pddl, _label(domain_pddl, "domain.pddl"))
    names = ObjectNames()
    constants = _lowered(constant_map, "constant_map")
    for constant in domain.constants:
        names.add_constant(constant.name, constants.get(constant.name, constant.name),
                           constant.type, mapped=constant.name in constants)
    atoms, values = _init(init, names)
    goal_formula = to_formula(goal, names)
    stream_file = _stream_file(stream_pddl)
    domain = declare_predicates(domain, atoms)  # predicates used only in init
    if stream_file is None:
        check_domain(domain)
    else:
        domain, stream_file = prepare_streams(stream_file, domain)
    objects = tuple(TypedName(n, names.types[n]) for n in names.table.names())
    parsed = syntax.Problem("pddlstream", domain.name, objects, tuple(atoms), tuple(values),
                            goal_formula)
    check_problem(parsed, domain)
    if isinstance(stream_map, str):
        if stream_map.lower() not in (DEBUG, SHARED_DEBUG):
            raise InputError(f"stream_map {stream_map!r}: expected a mapping of stream name "
                             "to procedure, DEBUG or SHARED_DEBUG")
        stream_map = debug_stream_map(stream_file, shared=stream_map.lower() == SHARED_DEBUG)
    factory = None
    if stream_file is not None:
        factory = _bindings_factory(stream_file, _lowered(stream_map, "stream_map"),
                                    _lowered(stream_info, "stream_info"))
    return with_negated_tests(PlanningProblem(
        "pddlstream", _label(domain_pddl, "domain.pddl"), domain, stream_file, factory,
        "stream_map", {}, {n: (names.types[n], names.table.value(n))
                           for n in names.table.names()},
        tuple(atoms), tuple(values), goal_formula))


@dataclass(frozen=True)
class DebugValue:
    """A placeholder output of a stream run in DEBUG mode: which stream, which output and
    (unless shared) which inputs it stands for."""

    stream: str
    output: str
    inputs: tuple[Any, ...] | None

    def __repr__(self) -> str:
        return f"#{self.output[1:]}<{self.stream}>"


def debug_stream_map(stream_file: StreamFile | None, shared: bool) -> dict[str, Any]:
    """Procedures for PDDLStream's DEBUG / SHARED_DEBUG modes: every stream yields one
    placeholder output per input tuple (shared: per stream), tests and predicates are true,
    functions cost 1."""
    procedures: dict[str, Any] = {}
    for stream in stream_file.streams if stream_file is not None else ():
        procedures[stream.name] = _debug_stream(stream, shared)
    for function in stream_file.functions if stream_file is not None else ():
        procedures[function.name] = fn_from_constant(1.0)
    for predicate in stream_file.predicates if stream_file is not None else ():
        procedures[predicate.name] = fn_from_constant(True)
    return procedures


def _debug_stream(stream: Stream, shared: bool) -> Callable[..., Any]:
    def placeholder(*inputs: Any, **_fluents: Any) -> Any:
        key = None if shared else tuple(_hashable(v) for v in inputs)
        return iter([[tuple(DebugValue(stream.name, out, key) for out in stream.outputs)]])
    return placeholder


def _hashable(value: Any) -> Any:
    try:
        hash(value)
    except TypeError:
        return id(value)
    return value


def _bindings_factory(stream_file: StreamFile, stream_map: dict[str, Any],
                      stream_info: dict[str, Info]
                      ) -> Callable[[Mapping[str, Any], Any], dict[str, Any]]:
    """``make_streams`` for the planner: each procedure adapted to its declaration."""
    externals: list[External] = [*stream_file.streams, *stream_file.functions,
                                 *stream_file.predicates]

    def make_streams(world: Mapping[str, Any], rng: Any) -> dict[str, Any]:
        provided: dict[str, Any] = {}
        for external in externals:
            procedure = stream_map.get(external.name)
            if procedure is None or not callable(procedure):
                if procedure is not None:
                    provided[external.name] = procedure  # reported as "not callable"
                continue
            provided[external.name] = Binding(_adapt(external, procedure),
                                              _planner_info(stream_info.get(external.name)))
        return provided

    return make_streams


def _planner_info(info: Info | None) -> PlannerStreamInfo:
    if info is None:
        return PlannerStreamInfo()
    defaults = PlannerStreamInfo()
    return PlannerStreamInfo(
        p_success=defaults.p_success if info.p_success is None else float(info.p_success),
        overhead=defaults.overhead if info.overhead is None else float(info.overhead),
        eager=bool(info.eager), opt_gen_fn=_partial_inputs(info))


def _partial_inputs(info: Info) -> PlannerPartialInputs | None:
    """``StreamInfo(opt_gen_fn=PartialInputs(inputs, unique))`` as the planner's; no
    ``opt_gen_fn``: the planner's default (one output shared by the instances with the same
    placeholder inputs, where PDDLStream shares it with all); another callable (a custom
    optimistic generator, which ltamp does not call): unique outputs."""
    opt_gen_fn = getattr(info, "opt_gen_fn", None)
    if opt_gen_fn is None:
        return None
    if isinstance(opt_gen_fn, PartialInputs):
        return PlannerPartialInputs(opt_gen_fn.inputs, opt_gen_fn.unique)
    return PlannerPartialInputs(unique=True)


def _adapt(external: External, procedure: Callable[..., Any]) -> Callable[..., Any]:
    """A PDDLStream procedure in the shape the planner calls (see
    :mod:`ltamp_cli.planner.streams`): generators of output lists for streams, booleans for
    tests and predicates, floats for functions."""
    if isinstance(external, StreamFunction):
        return procedure
    if isinstance(external, Stream) and not external.is_test:
        def generate(*inputs: Any, **kwargs: Any) -> Any:
            produced = procedure(*inputs, **kwargs)
            if produced is None:
                return iter(())
            if not isinstance(produced, Iterable) or isinstance(produced, str | bytes):
                raise _not_a_list_generator(external, produced)
            if type(produced) in FINITE_ITERATORS:
                # ``from_fn`` / ``from_list_fn``: a list that the planner can see the end
                # of, so that the instance is exhausted by its first call (a function).
                return iter([_batch(batch, external) for batch in produced])
            return (_batch(batch, external) for batch in produced)
        return generate

    def test(*inputs: Any, **kwargs: Any) -> bool | WildOutput:
        produced = procedure(*inputs, **kwargs)
        if produced is None or isinstance(produced, bool | np.bool_ | int | float):
            return bool(produced)
        if isinstance(produced, WildOutput):
            return produced
        first = next(iter(produced), [])
        if isinstance(first, WildOutput):
            return first
        if isinstance(first, list | tuple) and any(isinstance(v, WildOutput) for v in first):
            # from_gen_fn / from_fn / from_test put each item in an output list: the list
            # is "true" and its WildOutput's facts would be lost (a wrong "infeasible")
            raise _wrapped_wild_output(external)
        return bool(first)
    return test


def _wrapped_wild_output(external: External) -> InputError:
    """A test whose WildOutput came wrapped as one output tuple (PDDLStream refuses it too:
    "an output tuple is not a sequence")."""
    return InputError(f"stream {external.name!r}: its procedure gave a WildOutput wrapped as "
                      "an output (from_fn, from_gen_fn and from_test wrap what they are "
                      "given): put the function or generator function that returns or "
                      "yields WildOutput in stream_map itself",
                      getattr(external, "location", None))


def _not_a_list_generator(external: External, produced: Any) -> InputError:
    """A stream procedure that returned something no list generator gives (PDDLStream's
    procedures are wrapped by ``from_fn``, ``from_gen_fn``, ...)."""
    return InputError(f"stream {external.name!r}: its procedure gave {produced!r:.60}, not "
                      "lists of output tuples: wrap a function returning one output tuple "
                      "with from_fn, a generator function with from_gen_fn",
                      getattr(external, "location", None))


def _batch(batch: Any, external: External) -> list[Any] | WildOutput:
    """One item of a list generator as a list of output tuples (lists become tuples); a
    :class:`WildOutput` stays one."""
    if batch is None:
        return []
    if isinstance(batch, WildOutput):
        return batch
    if not isinstance(batch, tuple) and (not isinstance(batch, Iterable)
                                         or isinstance(batch, str | bytes)):
        raise _not_a_list_generator(external, batch)
    items = [batch] if isinstance(batch, tuple) else list(batch)
    return [tuple(item) if isinstance(item, list) else item for item in items if item is not None]
