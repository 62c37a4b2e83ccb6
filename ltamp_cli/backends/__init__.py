"""Physics backends. See :mod:`ltamp_cli.backends.protocol` for the interface.

Backends are looked up by name through :func:`load_backend`, which imports the backend's
module only when asked, so a missing optional dependency (e.g. SAPIEN) only matters to
users of that backend.

Other packages add backends (and with them skills) through the entry-point group
``ltamp.backends``: an entry ``slide = "my_package.slide:make_backend"`` in the plugin's
``pyproject.toml`` makes ``--backend slide`` work in every command. The backend module may
also define ``make_executor(**options)`` to execute plans (see
:mod:`ltamp_cli.backends.execution`). :func:`discover_backends` returns the current mapping;
nothing is registered globally.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from importlib.metadata import entry_points
from types import MappingProxyType, ModuleType
from typing import Any

from ltamp_cli.backends.protocol import (
    ParamSpace,
    SkillBackend,
    SkillSpec,
    TrialResult,
)
from ltamp_cli.errors import InputError
from ltamp_cli.extras import missing_module_hint

ENTRY_POINT_GROUP = "ltamp.backends"

# name -> "module:factory"; a factory takes keyword options and returns a SkillBackend.
BUILTIN_BACKENDS: Mapping[str, str] = MappingProxyType(
    {
        "synthetic": "ltamp_cli.backends.synthetic:make_backend",
        "box2d": "ltamp_cli.backends.box2d:make_backend",
        "pybullet": "ltamp_cli.backends.pybullet:make_backend",
        "sapien": "ltamp_cli.backends.sapien:make_backend",
    }
)


def discover_backends() -> Mapping[str, str]:
    """Every backend name -> ``"module:factory"``: the built-in ones, then the entry points
    of group ``ltamp.backends`` of the installed packages (a plugin cannot replace a
    built-in name; of two plugins with one name, the first found is used)."""
    found = dict(BUILTIN_BACKENDS)
    for entry in entry_points(group=ENTRY_POINT_GROUP):
        found.setdefault(entry.name, entry.value)
    return MappingProxyType(found)


def backend_module(name: str) -> tuple[ModuleType, str]:
    """Import the module of backend ``name``; returns it and its factory's name.

    Unknown names and modules that fail to import raise :class:`InputError`.
    """
    known = discover_backends()
    if name not in known:
        raise InputError(f"unknown backend {name!r}: expected one of {', '.join(sorted(known))}")
    module_name, _, factory_name = known[name].partition(":")
    try:
        module = importlib.import_module(module_name.strip())
    except ImportError as error:
        raise InputError(f"backend {name!r} is not available here: {error}"
                         f"{missing_module_hint(error)}") from None
    return module, factory_name.strip() or "make_backend"


def load_backend(name: str, **options: Any) -> SkillBackend:
    """Create the backend called ``name``; bad names raise :class:`InputError`."""
    module, factory_name = backend_module(name)
    factory = getattr(module, factory_name, None)
    if not callable(factory):
        raise InputError(f"backend {name!r}: {module.__name__} has no factory {factory_name!r}")
    try:
        return factory(**options)
    except ImportError as error:  # backends import their physics engine only when created
        raise InputError(f"backend {name!r} is not available here: {error}"
                         f"{missing_module_hint(error)}") from None
    except ValueError as error:  # e.g. a plugin's SkillSpec with a name used twice
        raise InputError(f"backend {name!r} ({module.__name__}): {error}") from None


def load_tagged_backend(tag: str) -> SkillBackend:
    """The backend that writes trials tagged ``tag`` (a record's or a model's ``backend``
    field): ``pybullet+panda`` is ``pybullet`` with ``robot="panda"``, a plain name is
    :func:`load_backend` of it. (``ltamp evaluate`` of a model trained with ``--robot panda``
    loaded ``"pybullet+panda"`` as a backend's name: "unknown backend".)"""
    name, _, robot = tag.partition("+")
    return load_backend(name, **({"robot": robot} if robot else {}))


__all__ = [
    "BUILTIN_BACKENDS",
    "ENTRY_POINT_GROUP",
    "ParamSpace",
    "SkillBackend",
    "SkillSpec",
    "TrialResult",
    "backend_module",
    "discover_backends",
    "load_backend",
    "load_tagged_backend",
]
