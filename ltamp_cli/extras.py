"""Optional dependencies: which ``ltamp[extra]`` provides a missing module.

Heavy parts a user may not need are extras of the ``ltamp`` distribution (see
``pyproject.toml``); when one is missing, commands say in one line what to install.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

# top-level module name -> the extra that installs it
MODULE_EXTRAS: Mapping[str, str] = MappingProxyType({
    "pybullet": "pybullet",
    "pybullet_data": "pybullet",
    "sapien": "sapien",
    "ray": "ray",
    "up_fast_downward": "fd",
    "fast_downward": "fd",
    "gpytorch": "gpytorch",
    "GPy": "dev",
})


def missing_module_hint(error: ImportError) -> str:
    """``"; install it with: pip install 'ltamp[EXTRA]'"`` when ``error`` is about a module of
    an extra, else ``""``."""
    top = (getattr(error, "name", None) or "").split(".")[0]
    extra = MODULE_EXTRAS.get(top)
    if extra is None:
        return ""
    return f"; install it with: pip install 'ltamp[{extra}]'"
