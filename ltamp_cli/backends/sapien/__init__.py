"""SAPIEN Kitchen3D backend: the PyBullet Kitchen3D scenes, skills and scores on PhysX.

Runs on machines without a GPU (a ``PhysxCpuSystem`` scene, collision shapes only) and
renders only after a child-process probe found a rendering device. Importing this package
is cheap and does not import SAPIEN; :func:`make_backend` does. Submodules: :mod:`.world`,
:mod:`.bodies` (kitchenware and beads), :mod:`.skills`, :mod:`.render`, :mod:`.backend`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ltamp_cli.backends.sapien.backend import SapienKitchen3DBackend


def make_backend(**options: Any) -> SapienKitchen3DBackend:
    """Create the SAPIEN Kitchen3D backend; see :class:`~.backend.SapienKitchen3DBackend`."""
    from ltamp_cli.backends.sapien.backend import SapienKitchen3DBackend

    return SapienKitchen3DBackend(**options)


__all__ = ["make_backend"]
