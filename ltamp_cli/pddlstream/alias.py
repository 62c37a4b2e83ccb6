"""An opt-in ``pddlstream`` import alias: PDDLStream scripts run with their imports unchanged.

A PDDLStream script says ``from pddlstream.algorithms.meta import solve`` or
``from pddlstream.utils import read, get_file_path``. :func:`install` puts a finder on
``sys.meta_path`` that serves every public ``pddlstream.*`` module path such scripts import
(:data:`SERVED`) with ltamp's equivalents from :mod:`ltamp_cli.pddlstream` and
:mod:`ltamp_cli.pddlstream.helpers`; :func:`uninstall` removes it and every module it
served; :func:`installed` is the context manager. Nothing happens at import time: importing
``ltamp_cli`` or ``ltamp_cli.pddlstream`` leaves ``sys.meta_path`` and ``sys.modules``
untouched.

Names ltamp lacks, in two kinds:

* PDDLStream names ltamp knows but does not provide (:data:`MISSING`: its internals such as
  ``SkeletonQueue``, ``OptimizerOutput``): importing one works (scripts import them and
  often never use them), using it raises :class:`MissingEquivalentError`, a
  ``NotImplementedError`` whose one line names the name, where the script used it and what
  to use instead. With ``strict=True`` the import itself raises :class:`AliasImportError`.
* Any other name or module under ``pddlstream``: the import raises
  :class:`AliasImportError` (an ``ImportError``; ``ModuleNotFoundError`` for modules), one
  line naming it.

If a real PDDLStream is importable, :func:`install` refuses to shadow it unless
``force=True`` (then the real modules already imported are set aside and restored by
:func:`uninstall`).
"""

from __future__ import annotations

import contextlib
import dis
import importlib
import importlib.abc
import importlib.machinery
import sys
import types
from collections.abc import Iterator, Mapping, Sequence
from typing import Any, NoReturn

from ltamp_cli.errors import InputError

API_MODULE = "ltamp_cli.pddlstream"
HELPERS_MODULE = "ltamp_cli.pddlstream.helpers"
DOCS = "docs/porting-from-pddlstream.md"

PACKAGES = frozenset({"pddlstream", "pddlstream.algorithms", "pddlstream.algorithms.scheduling",
                      "pddlstream.language", "pddlstream.retired"})

_CONSTANTS = (
    "AND", "EQ", "EXISTS", "FAILED", "FORALL", "IMPLY", "INCREASE", "INFEASIBLE", "MAXIMIZE",
    "MINIMIZE", "NOT", "OR", "PARAMETER", "TOTAL_COST", "TOTAL_TIME", "TYPE", "WHEN",
    "Action", "And", "Certificate", "Equal", "Exists", "Fact", "ForAll", "Imply", "Minimize",
    "Not", "Or", "Output", "PDDLProblem", "Solution", "get_args", "get_constraints",
    "get_length", "get_parameter_name", "get_prefix", "is_cost", "is_parameter", "is_plan",
    "partition_facts", "print_solution", "read_pddl_pair", "read_pddlstream_pair",
    "str_from_plan",
)
_GENERATORS = (
    "empty_gen", "empty_test", "fn_from_constant", "from_constant", "from_fn", "from_gen",
    "from_gen_fn", "from_list_fn", "from_list_gen_fn", "from_sampler", "from_test",
    "negate_test", "outputs_from_boolean", "universe_test",
)
_UTILS = (
    "INF", "SEPARATOR", "Profiler", "apply_mapping", "argmax", "argmin", "clip", "elapsed_time",
    "ensure_dir", "find", "find_unique", "flatten", "get_file_path", "get_mapping", "implies",
    "incoming_from_edges", "inf_generator", "invert_dict", "irange", "is_hashable", "lowercase",
    "negate_test", "neighbors_from_orders", "outgoing_from_edges", "randomize", "read",
    "read_pddl", "safe_apply_mapping", "safe_rm_dir", "safe_zip", "sorted_str_from_list",
    "str_eq", "str_from_object", "user_input", "value_or_id",
)
_SOLVERS = ("solve_adaptive", "solve_binding", "solve_focused", "solve_incremental")

# Module path -> the names it serves (looked up in HELPERS_MODULE, then API_MODULE).
SERVED: dict[str, tuple[str, ...]] = {
    "pddlstream": (),
    "pddlstream.algorithms": (),
    "pddlstream.algorithms.scheduling": (),
    "pddlstream.language": (),
    "pddlstream.retired": (),
    "pddlstream.algorithms.meta": ("solve", "create_parser", "ALGORITHMS",
                                   "FOCUSED_ALGORITHMS", *_SOLVERS, "PlanConstraints",
                                   "DEBUG", "SHARED_DEBUG", "PartialInputs", "Solution",
                                   "Certificate", "PDDLProblem", "is_plan", "get_prefix",
                                   "INF", "SEPARATOR", "elapsed_time", "irange",
                                   "analyze_goal"),
    "pddlstream.algorithms.focused": ("solve_focused", "solve_adaptive", "solve_binding",
                                      "INF", "elapsed_time"),
    "pddlstream.algorithms.incremental": ("solve_incremental", "INF", "elapsed_time"),
    "pddlstream.algorithms.search": ("solve_from_pddl",),
    "pddlstream.algorithms.constraints": ("PlanConstraints", "WILD", "OrderedSkeleton",
                                          "GOAL_INDEX", "linear_order"),
    "pddlstream.algorithms.downward": ("get_cost_scale", "set_cost_scale", "MAX_FD_COST"),
    "pddlstream.algorithms.satisfaction": ("SatisfactionProblem", "SatisfactionSolution",
                                           "constraint_satisfaction", "dump_assignment",
                                           "solve_pddlstream_satisfaction"),
    "pddlstream.retired.satisfaction": ("solve_pddlstream_satisfaction",
                                        "SatisfactionProblem", "SatisfactionSolution",
                                        "dump_assignment"),
    "pddlstream.algorithms.common": ("Solution", "INF"),
    "pddlstream.algorithms.visualization": ("VISUALIZATIONS_DIR",),
    "pddlstream.algorithms.skeleton": (),
    "pddlstream.algorithms.scheduling.plan_streams": (),
    "pddlstream.algorithms.recover_optimizers": (),
    "pddlstream.algorithms.reorder": (),
    "pddlstream.language.constants": _CONSTANTS,
    "pddlstream.language.generator": _GENERATORS,
    "pddlstream.language.stream": ("StreamInfo", "WildOutput", "PartialInputs", "DEBUG",
                                   "SHARED_DEBUG"),
    "pddlstream.language.function": ("FunctionInfo", "PredicateInfo", "add_opt_function"),
    "pddlstream.language.external": ("DEBUG", "SHARED_DEBUG", "defer_shared", "defer_unique",
                                     "get_defer_all_unbound", "get_defer_any_unbound",
                                     "never_defer"),
    "pddlstream.language.object": ("SharedOptValue", "UniqueOptValue"),
    "pddlstream.language.optimizer": (),
    "pddlstream.language.statistics": (),
    "pddlstream.language.temporal": ("DurativeAction", "retime_plan", "compute_duration",
                                     "compute_start", "compute_end", "get_start", "get_end"),
    "pddlstream.utils": _UTILS,
    # PDDLStream's switch modules: scripts set their module-level flags
    # (``instantiate_task.FD_INSTANTIATE = True``) to tune PDDLStream's own planner; here
    # setting them is accepted and has no effect.
    "pddlstream.algorithms.instantiate_task": (),
    "pddlstream.algorithms.instantiation": (),
    "pddlstream.algorithms.refinement": (),
    "pddlstream.language.exogenous": (),
}
SWITCH_MODULES = frozenset({"pddlstream.algorithms.instantiate_task",
                            "pddlstream.algorithms.instantiation",
                            "pddlstream.algorithms.refinement",
                            "pddlstream.language.exogenous"})

_INTERNALS = "one of PDDLStream's planner internals; ltamp's planner has its own"
_OPTIMIZERS = ("PDDLStream's :optimizer streams are not supported; write the optimizer as a "
               ":stream generator (from_gen_fn)")
# PDDLStream names ltamp knows and does not provide: module -> {name: what to do instead}.
MISSING: dict[str, dict[str, str]] = {
    "pddlstream.algorithms.search": {
        "ABSTRIPSLayer": "hierarchical (ABSTRIPS) search is not supported; drop the "
                         "hierarchy= option of solve",
    },
    "pddlstream.algorithms.common": {
        "SolutionStore": _INTERNALS + " (use solve)",
        "SOLUTIONS": _INTERNALS + " (solve returns the solution)",
    },
    "pddlstream.algorithms.skeleton": {
        "SkeletonQueue": _INTERNALS + " (solve(..., algorithm='adaptive') manages skeletons)",
    },
    "pddlstream.algorithms.scheduling.plan_streams": {
        "OptSolution": _INTERNALS,
    },
    "pddlstream.algorithms.recover_optimizers": {"combine_optimizers": _OPTIMIZERS},
    "pddlstream.algorithms.reorder": {"reorder_stream_plan": _INTERNALS},
    "pddlstream.algorithms.satisfaction": {
        "parse_value": _INTERNALS + " (SatisfactionSolution.bindings holds the values)",
    },
    "pddlstream.algorithms.visualization": {
        name: "ltamp draws no stream-plan graphs (PDDLStream writes them with graphviz)"
        for name in ("create_visualizations", "log_plans", "visualize_stream_plan")
    },
    "pddlstream.language.constants": {
        "OptPlan": _INTERNALS + " (solve returns Solution(plan, cost, certificate))",
    },
    "pddlstream.language.generator": {
        "accelerate_list_gen_fn": "not provided; use from_list_gen_fn",
    },
    "pddlstream.language.stream": {
        "Stream": _INTERNALS + "; declare streams in the stream file and bind them in "
                  "stream_map",
    },
    "pddlstream.language.function": {
        "Function": _INTERNALS + "; declare :function in the stream file and bind it in "
                    "stream_map",
    },
    "pddlstream.language.object": {
        "DebugValue": "ltamp's DEBUG placeholders are not DebugValue objects; compare with "
                      "the values your streams return instead",
    },
    "pddlstream.language.optimizer": {"OptimizerOutput": _OPTIMIZERS},
    "pddlstream.language.statistics": {
        "load_data": "the drop-in solve keeps no stream statistics (`ltamp solve` keeps "
                     "them in $XDG_CACHE_HOME/ltamp/)",
        "compute_plan_effort": _INTERNALS,
    },
    "pddlstream.utils": {
        "inclusive_range": "not provided; use numpy.arange or numpy.linspace",
        "read_pickle": "ltamp reads no pickles (data never runs code); use json",
        "write_pickle": "ltamp writes no pickles; use json",
    },
}


class AliasImportError(ImportError):
    """A ``pddlstream`` name or module that ltamp's alias does not provide (one line)."""


class AliasModuleNotFoundError(ModuleNotFoundError, AliasImportError):
    """A ``pddlstream.*`` module path that ltamp's alias does not provide (one line)."""


class MissingEquivalentError(NotImplementedError):
    """A PDDLStream name ltamp does not provide was used (one line: what, where, instead)."""


class AliasConflictError(InputError):
    """The alias cannot be installed: a real PDDLStream is importable, or it is installed."""


def _is_alias_path(fullname: str) -> bool:
    return fullname == "pddlstream" or fullname.startswith("pddlstream.")


def _caller() -> str:
    """``file:line: `` of the innermost frame outside this module and the import machinery
    (the user's line that imported or used the name); empty if there is none."""
    frame = sys._getframe(1)
    here = __file__
    while frame is not None:
        filename = frame.f_code.co_filename
        if (filename != here and not filename.startswith("<frozen importlib")
                and not filename.endswith(("importlib/__init__.py", "importlib\\__init__.py"))):
            return f"{filename}:{frame.f_lineno}: "
        frame = frame.f_back  # type: ignore[assignment]
    return ""


class MissingName:
    """Stands for a PDDLStream name ltamp lacks: importing it works, any use raises
    :class:`MissingEquivalentError` naming it, the script's line and what to use instead."""

    __slots__ = ("hint", "qualname")

    def __init__(self, qualname: str, hint: str) -> None:
        self.qualname = qualname
        self.hint = hint

    def message(self) -> str:
        return f"{self.qualname} is not provided by ltamp's pddlstream alias: {self.hint}"

    def _fail(self) -> NoReturn:
        raise MissingEquivalentError(_caller() + self.message())

    def __call__(self, *args: Any, **kwargs: Any) -> NoReturn:
        self._fail()

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):  # introspection (copy, inspect, namedtuple checks)
            raise AttributeError(name)
        self._fail()

    def __iter__(self) -> NoReturn:
        self._fail()

    def __getitem__(self, key: Any) -> NoReturn:
        self._fail()

    def __instancecheck__(self, instance: Any) -> bool:
        self._fail()

    def __subclasscheck__(self, subclass: Any) -> bool:
        self._fail()

    def __mro_entries__(self, bases: tuple[Any, ...]) -> NoReturn:
        self._fail()

    def __repr__(self) -> str:
        return f"<{self.qualname}: not provided by ltamp>"


_IMPORT_FROM = dis.opmap["IMPORT_FROM"]


def _in_import_from() -> bool:
    """Whether the attribute lookup in progress is a ``from module import NAME`` statement
    (the caller's frame is executing ``IMPORT_FROM``) rather than ``module.NAME``,
    ``hasattr`` or ``getattr``."""
    frame = sys._getframe(2)  # 0: here, 1: AliasModule.__getattr__, 2: its caller
    code = frame.f_code.co_code
    return 0 <= frame.f_lasti < len(code) and code[frame.f_lasti] == _IMPORT_FROM


class AliasAttributeError(AttributeError):
    """``module.NAME`` (or ``hasattr``) for a name an alias module does not provide."""


class AliasModule(types.ModuleType):
    """A ``pddlstream.*`` module served by the alias. ``from module import NAME`` of a public
    name it lacks raises :class:`AliasImportError` (one line: the script's line, the name,
    the hint); ``module.NAME`` raises :class:`AliasAttributeError` with the same line (so
    ``hasattr`` answers ``False``). Setting any attribute (PDDLStream's module-level
    switches) is allowed and has no effect on ltamp."""

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        submodule = f"{self.__name__}.{name}"
        if submodule in SERVED:  # `from pddlstream.algorithms import refinement`
            return importlib.import_module(submodule)
        error = AliasImportError if _in_import_from() else AliasAttributeError
        hint = MISSING.get(self.__name__, {}).get(name)
        if hint is not None:  # only reached when strict
            message = MissingName(submodule, hint).message()
        elif self.__name__ in SWITCH_MODULES:
            message = (f"{submodule}: one of PDDLStream's planner switches; ltamp's alias "
                       "accepts setting it (no effect) but has no value to read")
        else:
            what = (f"cannot import {name!r} from {self.__name__}" if error is AliasImportError
                    else f"{self.__name__} has no attribute {name!r}")
            message = (f"{what}: ltamp's pddlstream alias does not provide it (see {DOCS} for "
                       "what it provides)")
        raise error(_caller() + message, name=self.__name__ if error is AliasImportError
                    else name)


class PddlstreamAlias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """The finder and loader of the alias (see the module docstring). ``overrides`` maps a
    served name (``"solve"``) to the object to serve instead in every module that serves it,
    for instrumentation such as the examples bench."""

    def __init__(self, strict: bool = False, overrides: Mapping[str, Any] | None = None,
                 shadowed: Mapping[str, types.ModuleType] | None = None) -> None:
        self.strict = strict
        self.overrides = dict(overrides or {})
        served = {name for names in SERVED.values() for name in names}
        unknown = sorted(set(self.overrides) - served)
        if unknown:
            raise InputError(f"alias override {unknown[0]!r}: not a name the pddlstream alias "
                             "serves")
        self.shadowed = dict(shadowed or {})

    def find_spec(self, fullname: str, path: Sequence[str] | None = None,
                  target: types.ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        if not _is_alias_path(fullname):
            return None
        if fullname not in SERVED:
            raise AliasModuleNotFoundError(
                f"{_caller()}no module {fullname!r} in ltamp's pddlstream alias (it serves "
                f"PDDLStream's public modules: pddlstream.algorithms.meta, "
                f"pddlstream.language.generator, pddlstream.utils, ...; see {DOCS})",
                name=fullname)
        return importlib.machinery.ModuleSpec(fullname, self, origin="ltamp pddlstream alias",
                                              is_package=fullname in PACKAGES)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        return AliasModule(spec.name)

    def exec_module(self, module: types.ModuleType) -> None:
        api = importlib.import_module(API_MODULE)
        helpers = importlib.import_module(HELPERS_MODULE)
        names = SERVED[module.__name__]
        for name in names:
            if name in self.overrides:
                value = self.overrides[name]
            elif hasattr(helpers, name):
                value = getattr(helpers, name)
            else:
                value = getattr(api, name)
            setattr(module, name, value)
        missing = MISSING.get(module.__name__, {})
        if not self.strict:
            for name, hint in missing.items():
                setattr(module, name, MissingName(f"{module.__name__}.{name}", hint))
        module.__doc__ = (f"ltamp's stand-in for PDDLStream's {module.__name__} "
                          f"(ltamp_cli.pddlstream.alias).")
        module.__all__ = list(names) + ([] if self.strict else list(missing))  # type: ignore[attr-defined]


def is_installed() -> bool:
    """Whether an alias finder is on ``sys.meta_path``."""
    return any(isinstance(finder, PddlstreamAlias) for finder in sys.meta_path)


def real_pddlstream() -> str | None:
    """Where a real (non-alias) ``pddlstream`` would be imported from, or ``None``."""
    module = sys.modules.get("pddlstream")
    if module is not None and not isinstance(module, AliasModule) and getattr(
            module, "__file__", None):
        return str(module.__file__)
    for finder in sys.meta_path:
        if isinstance(finder, PddlstreamAlias) or not hasattr(finder, "find_spec"):
            continue
        try:
            spec = finder.find_spec("pddlstream", None)
        except (ImportError, ValueError):
            continue
        # A folder called pddlstream without __init__.py (a namespace package: data, a
        # scratch folder) is not a PDDLStream.
        if spec is not None and spec.origin not in (None, "namespace"):
            return str(spec.origin)
    return None


def install(*, force: bool = False, strict: bool = False,
            overrides: Mapping[str, Any] | None = None) -> PddlstreamAlias:
    """Serve ``pddlstream.*`` imports with ltamp's equivalents until :func:`uninstall`.

    ``strict``: PDDLStream names ltamp lacks fail at import instead of at use. ``force``:
    shadow a real PDDLStream that is importable (refused otherwise, one line).
    ``overrides``: ``{name: object}`` served instead of ltamp's ``name`` (instrumentation).
    Raises :class:`AliasConflictError` if refused or if an alias is already installed.
    """
    if is_installed():
        raise AliasConflictError("ltamp's pddlstream alias is already installed (uninstall() "
                                 "it first)")
    real = real_pddlstream()
    if real is not None and not force:
        raise AliasConflictError(
            f"a real PDDLStream is importable ({real}): ltamp's alias would shadow it; remove "
            "it from the path, or force the alias (install(force=True), `ltamp pddlstream run "
            "--force`)")
    shadowed = {name: module for name, module in sys.modules.items()
                if _is_alias_path(name) and not isinstance(module, AliasModule)}
    finder = PddlstreamAlias(strict, overrides, shadowed)
    for name in shadowed:
        del sys.modules[name]
    sys.meta_path.insert(0, finder)
    return finder


def uninstall(finder: PddlstreamAlias | None = None) -> bool:
    """Remove the alias (``finder``, or any) from ``sys.meta_path``, forget the modules it
    served and restore the real ones it shadowed; ``False`` if none was installed."""
    removed = [f for f in sys.meta_path
               if isinstance(f, PddlstreamAlias) and (finder is None or f is finder)]
    for alias in removed:
        sys.meta_path.remove(alias)
        for name, module in list(sys.modules.items()):
            spec = getattr(module, "__spec__", None)
            if _is_alias_path(name) and getattr(spec, "loader", None) is alias:
                del sys.modules[name]
        sys.modules.update(alias.shadowed)
    return bool(removed)


@contextlib.contextmanager
def installed(*, force: bool = False, strict: bool = False,
              overrides: Mapping[str, Any] | None = None) -> Iterator[PddlstreamAlias]:
    """``with installed(): import my_pddlstream_script`` (see :func:`install`)."""
    finder = install(force=force, strict=strict, overrides=overrides)
    try:
        yield finder
    finally:
        uninstall(finder)


def served_modules() -> list[str]:
    """Every ``pddlstream.*`` module path the alias serves."""
    return sorted(SERVED)


__all__ = [
    "MISSING", "SERVED", "AliasAttributeError", "AliasConflictError", "AliasImportError",
    "AliasModule", "AliasModuleNotFoundError", "MissingEquivalentError", "MissingName",
    "PddlstreamAlias",
    "install", "installed", "is_installed", "real_pddlstream", "served_modules", "uninstall",
]
