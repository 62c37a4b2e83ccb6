"""PyBullet Kitchen3D backend: procedural kitchenware, beads, pour, scoop, push and stir trials.

Importing this package is cheap; :func:`make_backend` imports the simulation modules.
Submodules: :mod:`.world` (one physics client per world), :mod:`.kitchenware` (bodies from
:mod:`ltamp_cli.backends.kitchenware_geometry`), :mod:`.particles`, :mod:`.skills`,
:mod:`.render`, :mod:`.backend`; :mod:`.robot` holds the arm side.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ltamp_cli.backends.pybullet.backend import Kitchen3DBackend
    from ltamp_cli.backends.pybullet.executor import Kitchen3DExecutor


def make_backend(**options: Any) -> Kitchen3DBackend:
    """Create the Kitchen3D backend; see :class:`~.backend.Kitchen3DBackend` for options."""
    from ltamp_cli.backends.pybullet.backend import Kitchen3DBackend

    return Kitchen3DBackend(**options)


def make_executor(**options: Any) -> Kitchen3DExecutor:
    """Create the kitchen3d plan executor (see :mod:`ltamp_cli.backends.execution`)."""
    from ltamp_cli.backends.pybullet.executor import Kitchen3DExecutor

    return Kitchen3DExecutor(**options)


__all__ = ["make_backend", "make_executor"]
