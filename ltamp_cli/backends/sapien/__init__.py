"""SAPIEN Kitchen3D backend: the PyBullet Kitchen3D scenes, skills and scores on PhysX.

Runs on machines without a GPU (a ``PhysxCpuSystem`` scene, collision shapes only) and
renders only after a child-process probe found a rendering device. Importing this package
is cheap and does not import SAPIEN; :func:`make_backend` does. Submodules: :mod:`.world`,
:mod:`.bodies` (kitchenware and beads), :mod:`.skills`, :mod:`.render`, :mod:`.backend`,
:mod:`.executor` (plan replay), :mod:`.replay` (CPU rendering of a recorded execution).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ltamp_cli.backends.sapien.backend import SapienKitchen3DBackend
    from ltamp_cli.backends.sapien.executor import SapienKitchen3DExecutor


def make_backend(**options: Any) -> SapienKitchen3DBackend:
    """Create the SAPIEN Kitchen3D backend; see :class:`~.backend.SapienKitchen3DBackend`."""
    from ltamp_cli.backends.sapien.backend import SapienKitchen3DBackend

    return SapienKitchen3DBackend(**options)


def make_executor(**options: Any) -> SapienKitchen3DExecutor:
    """Create the kitchen3d plan executor on SAPIEN (see :mod:`ltamp_cli.backends.execution`)."""
    from ltamp_cli.backends.sapien.executor import SapienKitchen3DExecutor

    return SapienKitchen3DExecutor(**options)


__all__ = ["make_backend", "make_executor"]
