"""NumPy-1 names for a PDDLStream script run by :mod:`ltamp_cli.pddlstream.run`.

PDDLStream projects are mostly written for NumPy 1 (``from numpy import mat``,
``np.product``, ``np.float_``, ``np.NaN``). NumPy 2.0 removed about a hundred names from its
main namespace (the NumPy 2.0 migration guide; NumPy's own ``_expired_attrs_2_0.py``) and
deprecated ``in1d``, ``trapz`` and ``row_stack``, which later releases remove (``in1d`` and
``trapz`` are gone in NumPy 2.4). :func:`install` adds back,
on the ``numpy`` module of the running process, the removed names in :data:`LEGACY` that
have an *exact* NumPy 2 equivalent: the same object under its new name or place
(``mat`` is ``np.asmatrix``, ``float_`` is ``np.float64``, ``DataSource`` is
``np.lib.npyio.DataSource``), the same value (``NaN``, ``Inf``, ``NINF``), or a one-line
wrapper computing exactly what NumPy 1 computed (``in1d``, ``msort``).

Only names the installed NumPy lacks are added; an existing attribute is never replaced
(under NumPy 1, or NumPy 2.0-2.3 where ``in1d``/``trapz`` still exist, those stay NumPy's
own). Removed names without an exact equivalent (``asfarray``, ``cast``, ``obj2sctype``,
``issubclass_``, ``find_common_type``, ``who``, ...; :data:`NOT_RESTORED`) stay absent: the
script's ``AttributeError`` or ``ImportError`` is NumPy's own. The added names are also
appended to ``numpy.__all__`` (they were in NumPy 1's, so ``from numpy import *`` finds
them). :func:`uninstall` removes exactly what :func:`install` added and restores
``numpy.__all__``.

Nothing happens at import time. Only the runner installs it, for the script's process
(``--no-numpy-compat`` switches it off); importing ``ltamp_cli``, the drop-in API or the
CLI leaves ``numpy`` untouched.
"""

from __future__ import annotations

import contextlib
import types
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Legacy:
    """One removed NumPy name: ``name``, ``equivalent`` (the NumPy 2 spelling, for the
    docs) and ``resolve(numpy) -> object`` (raises ``AttributeError`` if this NumPy lacks
    the equivalent too)."""

    name: str
    equivalent: str
    resolve: Callable[[types.ModuleType], Any]


def _attr(path: str) -> Callable[[types.ModuleType], Any]:
    """``numpy.<path>`` (dotted, e.g. ``lib.npyio.DataSource``) of the given numpy module."""

    def resolve(numpy: types.ModuleType) -> Any:
        value: Any = numpy
        for part in path.split("."):
            value = getattr(value, part)
        return value

    return resolve


def _value(value: float) -> Callable[[types.ModuleType], Any]:
    """A constant (NumPy 1's ``NINF``, ``PZERO``, ``NZERO`` were plain floats)."""
    return lambda numpy: value


def _in1d(numpy: types.ModuleType) -> Callable[..., Any]:
    """NumPy 1's ``in1d``: ``isin`` on the flattened first argument (1-D bool result)."""
    isin = numpy.isin

    def in1d(ar1: Any, ar2: Any, assume_unique: bool = False, invert: bool = False, *,
             kind: str | None = None) -> Any:
        """``numpy.isin(numpy.ravel(ar1), ar2, ...)``: NumPy 1's ``in1d`` (a 1-D boolean
        array, one entry per element of ``ar1`` flattened)."""
        return isin(numpy.asarray(ar1).ravel(), ar2, assume_unique=assume_unique,
                    invert=invert, kind=kind)

    in1d.__module__ = "numpy"
    return in1d


def _msort(numpy: types.ModuleType) -> Callable[..., Any]:
    """NumPy 1's ``msort``: a sorted copy along the first axis."""
    sort = numpy.sort

    def msort(a: Any) -> Any:
        """``numpy.sort(a, axis=0)``: NumPy 1's ``msort`` (a copy sorted along axis 0)."""
        return sort(a, axis=0)

    msort.__module__ = "numpy"
    return msort


# The removed names restored, with their exact NumPy 2 equivalents. Sources: the NumPy 2.0
# migration guide (main namespace: removed and deprecated members), the NumPy 1.24/1.25
# deprecations expired in 2.0 (product, cumproduct, sometrue, alltrue, round_, msort, the
# scalar aliases ending in 0, bool8) and the members 2.0 deprecated (in1d, trapz, row_stack).
LEGACY: tuple[Legacy, ...] = (
    # Functions: the same function under its NumPy 2 name.
    Legacy("mat", "numpy.asmatrix", _attr("asmatrix")),
    Legacy("product", "numpy.prod", _attr("prod")),
    Legacy("cumproduct", "numpy.cumprod", _attr("cumprod")),
    Legacy("sometrue", "numpy.any", _attr("any")),
    Legacy("alltrue", "numpy.all", _attr("all")),
    Legacy("round_", "numpy.round", _attr("round")),
    Legacy("row_stack", "numpy.vstack", _attr("vstack")),
    Legacy("trapz", "numpy.trapezoid", _attr("trapezoid")),
    Legacy("in1d", "numpy.isin(numpy.ravel(ar1), ar2, ...)", _in1d),
    Legacy("msort", "numpy.sort(a, axis=0)", _msort),
    # Moved, same object.
    Legacy("add_docstring", "numpy.lib.add_docstring", _attr("lib.add_docstring")),
    Legacy("add_newdoc", "numpy.lib.add_newdoc", _attr("lib.add_newdoc")),
    Legacy("byte_bounds", "numpy.lib.array_utils.byte_bounds",
           _attr("lib.array_utils.byte_bounds")),
    Legacy("compare_chararrays", "numpy.char.compare_chararrays",
           _attr("char.compare_chararrays")),
    Legacy("format_parser", "numpy.rec.format_parser", _attr("rec.format_parser")),
    Legacy("DataSource", "numpy.lib.npyio.DataSource", _attr("lib.npyio.DataSource")),
    Legacy("tracemalloc_domain", "numpy.lib.tracemalloc_domain",
           _attr("lib.tracemalloc_domain")),
    # Scalar type aliases: the same type.
    Legacy("float_", "numpy.float64", _attr("float64")),
    Legacy("complex_", "numpy.complex128", _attr("complex128")),
    Legacy("cfloat", "numpy.complex128", _attr("complex128")),
    Legacy("singlecomplex", "numpy.complex64", _attr("complex64")),
    Legacy("longfloat", "numpy.longdouble", _attr("longdouble")),
    Legacy("longcomplex", "numpy.clongdouble", _attr("clongdouble")),
    Legacy("clongfloat", "numpy.clongdouble", _attr("clongdouble")),
    Legacy("string_", "numpy.bytes_", _attr("bytes_")),
    Legacy("unicode_", "numpy.str_", _attr("str_")),
    Legacy("int0", "numpy.intp", _attr("intp")),
    Legacy("uint0", "numpy.uintp", _attr("uintp")),
    Legacy("bool8", "numpy.bool_", _attr("bool_")),
    Legacy("object0", "numpy.object_", _attr("object_")),
    Legacy("str0", "numpy.str_", _attr("str_")),
    Legacy("bytes0", "numpy.bytes_", _attr("bytes_")),
    Legacy("void0", "numpy.void", _attr("void")),
    # Constants: the same float value.
    Legacy("NaN", "numpy.nan", _attr("nan")),
    Legacy("Inf", "numpy.inf", _attr("inf")),
    Legacy("Infinity", "numpy.inf", _attr("inf")),
    Legacy("infty", "numpy.inf", _attr("inf")),
    Legacy("PINF", "numpy.inf", _attr("inf")),
    Legacy("NINF", "-numpy.inf", _value(float("-inf"))),
    Legacy("PZERO", "0.0", _value(0.0)),
    Legacy("NZERO", "-0.0", _value(-0.0)),
)

# Removed names left absent: no exact equivalent (the migration guide's advice changes
# behaviour: other dtypes, error handling or return types) or no equivalent at all.
NOT_RESTORED: tuple[str, ...] = (
    "add_newdoc_ufunc", "asfarray", "cast", "compat", "deprecate", "deprecate_with_doc",
    "disp", "fastCopyAndTranspose", "find_common_type", "get_array_wrap", "geterrobj",
    "issctype", "issubclass_", "issubsctype", "lookfor", "maximum_sctype", "nbytes",
    "obj2sctype", "recfromcsv", "recfromtxt", "safe_eval", "sctype2char", "sctypes",
    "set_numeric_ops", "set_string_function", "seterrobj", "source", "who",
)


@dataclass
class NumpyCompat:
    """What :func:`install` did to one ``numpy`` module: ``added`` maps each added name to
    the object set; ``saved_all`` is ``numpy.__all__`` before (restored by uninstall)."""

    numpy: types.ModuleType
    added: dict[str, Any] = field(default_factory=dict)
    saved_all: Any = None


def _lacks(numpy: types.ModuleType, name: str) -> bool:
    """Whether ``numpy.name`` does not resolve (a name served by NumPy's own module
    ``__getattr__``, possibly with a deprecation warning, counts as present)."""
    if name in vars(numpy):
        return False
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            getattr(numpy, name)
        except AttributeError:
            return True
    return False


def install(numpy: types.ModuleType | None = None) -> NumpyCompat:
    """Add the :data:`LEGACY` names ``numpy`` lacks (default: the imported ``numpy``);
    return the record for :func:`uninstall`. Never replaces an attribute; skips a name
    whose equivalent this NumPy lacks too."""
    if numpy is None:
        import numpy as imported

        numpy = imported
    compat = NumpyCompat(numpy)
    for legacy in LEGACY:
        if not _lacks(numpy, legacy.name):
            continue
        try:
            value = legacy.resolve(numpy)
        except AttributeError:  # an older or newer NumPy without the equivalent
            continue
        setattr(numpy, legacy.name, value)
        compat.added[legacy.name] = value
    exported = getattr(numpy, "__all__", None)
    if compat.added and isinstance(exported, (list, tuple)):
        compat.saved_all = exported
        numpy.__all__ = [*exported, *(n for n in compat.added if n not in exported)]
    return compat


def uninstall(compat: NumpyCompat) -> None:
    """Remove what :func:`install` added (a name the script rebound itself stays) and
    restore ``numpy.__all__``."""
    numpy = compat.numpy
    for name, value in compat.added.items():
        if vars(numpy).get(name, _MISSING) is value:
            delattr(numpy, name)
    if compat.saved_all is not None:
        numpy.__all__ = compat.saved_all
    compat.added.clear()
    compat.saved_all = None


_MISSING = object()


@contextlib.contextmanager
def installed(numpy: types.ModuleType | None = None) -> Iterator[NumpyCompat]:
    """:func:`install` for the ``with`` block, then :func:`uninstall`."""
    compat = install(numpy)
    try:
        yield compat
    finally:
        uninstall(compat)
