"""Physics backends. See :mod:`ltamp_cli.backends.protocol` for the interface.

Backends are looked up by name through :func:`load_backend`, which imports the backend's
module only when asked, so a missing optional dependency (e.g. SAPIEN) only matters to
users of that backend.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

from ltamp_cli.backends.protocol import (
    ParamSpace,
    SkillBackend,
    SkillSpec,
    TrialResult,
)
from ltamp_cli.errors import InputError

# name -> "module:factory"; a factory takes keyword options and returns a SkillBackend.
BACKEND_FACTORIES: Mapping[str, str] = MappingProxyType(
    {
        "synthetic": "ltamp_cli.backends.synthetic:make_backend",
        "box2d": "ltamp_cli.backends.box2d:make_backend",
        "pybullet": "ltamp_cli.backends.pybullet:make_backend",
        "sapien": "ltamp_cli.backends.sapien:make_backend",
    }
)


def load_backend(name: str, **options: Any) -> SkillBackend:
    """Create the backend called ``name``; bad names raise :class:`InputError`."""
    if name not in BACKEND_FACTORIES:
        known = ", ".join(sorted(BACKEND_FACTORIES))
        raise InputError(f"unknown backend {name!r}: expected one of {known}")
    module_name, factory_name = BACKEND_FACTORIES[name].split(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as error:
        raise InputError(f"backend {name!r} is not available here: {error}") from error
    return getattr(module, factory_name)(**options)


__all__ = [
    "BACKEND_FACTORIES",
    "ParamSpace",
    "SkillBackend",
    "SkillSpec",
    "TrialResult",
    "load_backend",
]
