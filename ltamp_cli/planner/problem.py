"""Planning problems from YAML files (or PDDL problem files) and their domains.

A YAML problem::

    name: tamp2d-blocked
    domain: ../../domains/tamp2d          # folder with domain.pddl (+ stream.pddl)
    bindings: ../../domains/tamp2d/streams.py   # a .py file, or an importable module
    world: {...}                           # passed to the bindings' make_streams()
    objects:                               # name: value  or  name: {type: T, value: V}
      b1: null                             # null → a symbolic object
      p1: [0.0, 0.0]
    init: ["(Block b1)", "(AtPose b1 p1)"]
    goal: "(and (In b1 goal))"
    planner: {algorithm: focused, max_time: 30}   # optional defaults

Instead of ``objects``/``init``/``goal`` a YAML file may name ``pddl_problem: FILE.pddl``.
Relative paths are relative to the YAML file.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.util
import re
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ltamp_cli.errors import InputError, SourceLocation
from ltamp_cli.extras import missing_module_hint
from ltamp_cli.planner.pddl.check import check_domain, check_problem, prepare_streams
from ltamp_cli.planner.pddl.negation import guard_negated_tests
from ltamp_cli.planner.pddl.parse import (
    parse_domain,
    parse_formula,
    parse_init_item,
    parse_problem,
    parse_stream_file,
    read_text,
)
from ltamp_cli.planner.pddl.sexpr import read_sexprs
from ltamp_cli.planner.pddl.syntax import (
    OBJECT_TYPE,
    Atom,
    Domain,
    Formula,
    FunctionValue,
    Problem,
    StreamFile,
    TypedName,
)
from ltamp_cli.planner.problem_schema import validate_problem_document
from ltamp_cli.planner.search.skeleton import check_constraints, parse_constraints
from ltamp_cli.shipped import resolve_problem_path
from ltamp_cli.yamlfile import YamlDocument

BINDINGS_FACTORY = "make_streams"


@dataclass
class PlanningProblem:
    """Everything a planner needs, resolved and checked."""

    name: str
    path: str
    domain: Domain
    stream_file: StreamFile | None
    streams_factory: Callable[..., Mapping[str, Any]] | None
    bindings_source: str
    world: Mapping[str, Any]
    objects: dict[str, tuple[str, Any]]  # name -> (type, value or None)
    init: tuple[Atom, ...]
    function_values: tuple[FunctionValue, ...]
    goal: Formula
    planner_options: dict[str, Any] = field(default_factory=dict)
    raw: Mapping[str, Any] = field(default_factory=dict)
    # Where the goal was written (YAML ``goal:``, a PDDL problem file): refusals of the goal
    # found while solving (a formula too large to expand) name it. None: built in Python.
    goal_location: SourceLocation | None = None


def _path_error(path: Path, what: str, where: SourceLocation) -> InputError | None:
    """Why ``path`` cannot be used (too long a name, not a folder, ...), if it cannot."""
    try:
        path.stat()
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as error:  # ENAMETOOLONG, ELOOP, a NUL byte ...
        reason = getattr(error, "strerror", None) or str(error)
        return InputError(f"{what} {str(path)[:120]!r}: {reason}", where)
    return None


def load_domain(folder: Path, where: SourceLocation) -> tuple[Domain, StreamFile | None]:
    problem = _path_error(folder, "domain folder", where)
    if problem is not None:
        raise problem
    if not folder.is_dir():
        raise InputError(f"domain folder {str(folder)!r} does not exist", where)
    domain_path = folder / "domain.pddl"
    if not domain_path.exists():
        raise InputError(f"no domain.pddl in {str(folder)!r}", where)
    domain = parse_domain(read_text(domain_path, "domain file"), domain_path)
    stream_path = folder / "stream.pddl"
    if not stream_path.exists():
        check_domain(domain)
        return domain, None
    stream_file = parse_stream_file(read_text(stream_path, "stream file"), stream_path)
    return prepare_streams(stream_file, domain)


def load_streams_factory(spec: str, base: Path, where: SourceLocation
                         ) -> Callable[..., Mapping[str, Any]]:
    """Import the bindings (a ``.py`` file or a module) and return its ``make_streams``."""
    if spec.endswith(".py"):
        problem = _path_error(base / spec, "bindings file", where)
        if problem is not None:
            raise problem
        path = (base / spec).resolve()
        if not path.exists():
            raise InputError(f"bindings file {spec!r} not found", where)
        module_name = "ltamp_bindings_" + hashlib.sha1(str(path).encode()).hexdigest()[:12]
        module = sys.modules.get(module_name)
        if module is None:
            loader_spec = importlib.util.spec_from_file_location(module_name, path)
            if loader_spec is None or loader_spec.loader is None:
                raise InputError(f"cannot import bindings file {spec!r}", where)
            module = importlib.util.module_from_spec(loader_spec)
            sys.modules[module_name] = module
            try:
                loader_spec.loader.exec_module(module)
            except KeyboardInterrupt:
                del sys.modules[module_name]
                raise
            except BaseException as error:  # user code, even SystemExit: one line
                del sys.modules[module_name]
                raise InputError(f"bindings file {spec!r} failed to import: "
                                 f"{type(error).__name__}: {error}"
                                 f"{_install_hint(error)}", where) from None
    else:
        try:
            module = importlib.import_module(spec)
        except KeyboardInterrupt:
            raise
        except BaseException as error:  # user code, even SystemExit: one line
            raise InputError(f"bindings module {spec!r} failed to import: "
                             f"{type(error).__name__}: {error}"
                             f"{_install_hint(error)}", where) from None
    factory = getattr(module, BINDINGS_FACTORY, None)
    if not callable(factory):
        raise InputError(f"bindings {spec!r} define no {BINDINGS_FACTORY}(world, rng) function",
                         where)
    return factory


def _install_hint(error: Exception) -> str:
    """How to install the optional dependency whose absence ``error`` reports ('' if none)."""
    return missing_module_hint(error) if isinstance(error, ImportError) else ""


_WORLD_PATH = re.compile(r"world((?:\s*[.:]\s*[\w\-]+)*)")


def world_error_location(doc: YamlDocument, message: str) -> SourceLocation:
    """Where a bindings/backend error about ``world`` points in the YAML file.

    Backends name the field at the start of their messages (``world.regions.table: ...``,
    ``world: layout: unknown field ...``); the deepest node of that path that exists in the
    file is reported (the ``world`` block itself if none does).
    """
    match = _WORLD_PATH.match(message)
    parts = re.split(r"\s*[.:]\s*", match.group(1).strip(" .:")) if match else []
    return doc.location("world", *[part for part in parts if part])


def _locating_world_errors(factory: Callable[..., Mapping[str, Any]], doc: YamlDocument
                           ) -> Callable[..., Mapping[str, Any]]:
    """``factory`` whose location-less ``world`` errors get the YAML position of the field."""

    @functools.wraps(factory)  # keeps the bindings module's name (__module__) visible
    def make_streams(world: Mapping[str, Any], rng: Any) -> Mapping[str, Any]:
        try:
            return factory(world, rng)
        except KeyboardInterrupt:
            raise
        except InputError as error:
            if error.location is not None or not error.message.startswith("world"):
                raise
            raise InputError(error.message, world_error_location(doc, error.message)) from None

    return make_streams


def _parse_objects(doc: YamlDocument, domain: Domain) -> dict[str, tuple[str, Any]]:
    raw = doc.get("objects", default={}) or {}
    if not isinstance(raw, dict):
        raise doc.error("'objects' must be a mapping of object name to value", "objects")
    known_types = {OBJECT_TYPE, *(c for c, _ in domain.types), *(p for _, p in domain.types)}
    objects: dict[str, tuple[str, Any]] = {}
    for name, value in raw.items():
        key = str(name)
        lowered = key.lower()
        if not lowered or lowered.startswith(("?", ":", "@", "#")) or any(
                c.isspace() or c in "()" for c in lowered):
            raise doc.error(f"invalid object name {key!r}", "objects", name)
        type_name = OBJECT_TYPE
        if isinstance(value, dict) and ("type" in value or "value" in value):
            extra = set(value) - {"type", "value"}
            if extra:
                raise doc.error(f"unexpected field {sorted(extra)[0]!r} for object {key!r}: "
                                "expected 'type' and/or 'value'", "objects", name)
            type_name = str(value.get("type", OBJECT_TYPE)).lower()
            value = value.get("value")
        if type_name not in known_types:
            raise doc.error(f"unknown type {type_name!r} for object {key!r}: expected one of "
                            f"{', '.join(sorted(known_types))}", "objects", name)
        objects[lowered] = (type_name, value)
    for constant in domain.constants:
        objects.setdefault(constant.name, (constant.type, None))
    return objects


def _parse_facts(doc: YamlDocument) -> tuple[list[Atom], list[FunctionValue]]:
    raw = doc.get("init", default=[]) or []
    if not isinstance(raw, list):
        raise doc.error("'init' must be a list of facts such as \"(AtPose b1 p1)\"", "init")
    atoms: list[Atom] = []
    values: list[FunctionValue] = []
    for index, item in enumerate(raw):
        if not isinstance(item, str):
            raise doc.error("each init fact must be a string such as \"(AtPose b1 p1)\"",
                            "init", index)
        line, column = doc.text_origin("init", index)
        exprs = read_sexprs(item, doc.path, line, column)
        if len(exprs) != 1:
            raise doc.error("expected exactly one fact per list item", "init", index)
        parsed = parse_init_item(exprs[0])
        (values if isinstance(parsed, FunctionValue) else atoms).append(parsed)
    return atoms, values


def _parse_goal(doc: YamlDocument) -> Formula:
    raw = doc.get("goal")
    if not isinstance(raw, str):
        raise doc.error("'goal' must be a formula string such as \"(and (On a b))\"", "goal")
    line, column = doc.text_origin("goal")
    exprs = read_sexprs(raw, doc.path, line, column)
    if len(exprs) != 1:
        raise doc.error("'goal' must hold exactly one formula", "goal")
    return parse_formula(exprs[0], "the goal")


def load_problem(path: str | Path, domain_dir: str | Path | None = None) -> PlanningProblem:
    """Load a YAML problem (or a PDDL problem file with ``domain_dir``) and check it.

    ``path`` may also be a built-in problem name such as ``kitchen2d/coffee`` (see
    :func:`ltamp_cli.shipped.resolve_problem_path`).
    """
    path = resolve_problem_path(path)
    if path.suffix == ".pddl":
        if domain_dir is None:
            raise InputError("a PDDL problem file needs its domain folder (--domain DIR)",
                             SourceLocation(str(path)))
        domain, stream_file = load_domain(Path(domain_dir), SourceLocation(str(path)))
        if stream_file is not None and stream_file.external_names():
            raise InputError("this domain has streams: use a YAML problem that names its "
                             "bindings", SourceLocation(str(path)))
        return _from_pddl_problem(path, domain, str(path), {})
    doc = YamlDocument(path)
    if isinstance(doc.data, dict) and not isinstance(doc.get("domain"), str):
        raise doc.error("'domain' must name the domain folder (with domain.pddl)", "domain")
    # Structure first (unknown keys, types, required fields), then the meaning of the values.
    validate_problem_document(doc)
    base = path.parent
    domain_field = doc.get("domain")
    domain, stream_file = load_domain((base / domain_field), doc.location("domain"))
    planner_options = doc.get("planner", default={}) or {}
    if not isinstance(planner_options, dict):
        raise doc.error("'planner' must be a mapping of planner options", "planner")
    _check_plan_constraints(doc, planner_options, domain)
    world = doc.get("world", default={}) or {}
    if not isinstance(world, dict):
        raise doc.error("'world' must be a mapping", "world")
    _check_learned_stream_names(doc, world, stream_file)
    factory = None
    bindings_source = ""
    if stream_file is not None and stream_file.external_names():
        spec = doc.get("bindings")
        if not isinstance(spec, str):
            raise doc.error("the domain has streams: 'bindings' must name a .py file or a "
                            "module that defines make_streams(world, rng)", "bindings")
        factory = _locating_world_errors(load_streams_factory(spec, base,
                                                              doc.location("bindings")), doc)
        bindings_source = spec
    if doc.get("pddl_problem") is not None:
        problem_path = base / str(doc.get("pddl_problem"))
        loaded = _from_pddl_problem(problem_path, domain, str(path), dict(planner_options))
        loaded.stream_file, loaded.streams_factory = stream_file, factory
        loaded.bindings_source, loaded.world, loaded.raw = bindings_source, world, doc.data
        return with_negated_tests(loaded)
    objects = _parse_objects(doc, domain)
    atoms, values = _parse_facts(doc)
    goal = _parse_goal(doc)
    typed = tuple(TypedName(name, type_name) for name, (type_name, _) in objects.items())
    problem = Problem(str(doc.get("name", path.stem)), domain.name, typed, tuple(atoms),
                      tuple(values), goal, False, doc.location())
    check_problem(problem, domain)
    return with_negated_tests(PlanningProblem(
        problem.name, str(path), domain, stream_file, factory, bindings_source, world, objects,
        problem.init, problem.function_values, goal, dict(planner_options), doc.data,
        doc.location("goal")))


def _check_plan_constraints(doc: YamlDocument, options: Mapping[str, Any],
                            domain: Domain) -> None:
    """The planner options' skeletons name actions of the domain with their numbers of
    arguments (a misspelt pattern would only make the problem infeasible); errors point at
    the skeleton in the file."""
    given = [key for key in ("skeleton", "skeletons") if options.get(key)]
    if len(given) > 1:
        raise doc.error("plan constraints given twice (skeleton and skeletons): give one "
                        "skeleton or a list of skeletons", "planner", "skeletons")
    if not given:
        return
    located: list[tuple[tuple[str | int, ...], list[Any]]]
    if given == ["skeleton"]:
        located = [(("skeleton",), [options["skeleton"]])]
    else:
        skeletons = list(options["skeletons"])
        located = [(("skeletons", index), [entries]) for index, entries in enumerate(skeletons)]
        located.append((("skeletons",), skeletons))  # together: their gaps must agree
    arities = {action.name: len(action.parameters) for action in domain.actions}
    for keys, entries in located:
        try:
            constraints = parse_constraints(entries)
            if constraints is not None:
                check_constraints(constraints, arities)
        except InputError as error:
            raise doc.error(str(error), "planner", *keys) from None


def _check_learned_stream_names(doc: YamlDocument, world: Mapping[str, Any],
                                stream_file: StreamFile | None) -> None:
    """Every ``world.learned_streams`` entry must name a stream of the stream file: the
    bindings look entries up by stream name, so a misspelt one would be ignored silently."""
    entries = world.get("learned_streams")
    if not isinstance(entries, Mapping):
        return
    streams = [s.name for s in stream_file.streams] if stream_file is not None else []
    known = {name.lower() for name in streams}
    for key in entries:
        if str(key).lower() not in known:
            raise doc.error(f"world.learned_streams.{key}: the stream file has no stream "
                            f"{str(key)!r} (streams: {', '.join(streams) or 'none'})",
                            "world", "learned_streams", key)


def with_negated_tests(problem: PlanningProblem) -> PlanningProblem:
    """``problem`` with the test facts its formulas need false compiled into negated tests,
    as PDDLStream plans with them (:mod:`ltamp_cli.planner.pddl.negation`)."""
    if problem.stream_file is None:
        return problem
    domain, stream_file, goals = guard_negated_tests(problem.domain, problem.stream_file,
                                                     [problem.goal],
                                                     {atom.predicate for atom in problem.init})
    if domain is problem.domain:
        return problem
    return replace(problem, domain=domain, stream_file=stream_file, goal=goals[0])


def _from_pddl_problem(path: Path, domain: Domain, source: str, options: dict[str, Any]
                       ) -> PlanningProblem:
    problem = parse_problem(read_text(path, "problem file"), path)
    check_problem(problem, domain)
    objects = {o.name: (o.type, None) for o in problem.objects}
    for constant in domain.constants:
        objects.setdefault(constant.name, (constant.type, None))
    return PlanningProblem(problem.name, source, domain, None, None, "", {}, objects,
                           problem.init, problem.function_values, problem.goal, options, {},
                           problem.location)
