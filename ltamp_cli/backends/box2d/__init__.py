"""Kitchen2D: a 2D kitchen on Box2D with a free-flying two-finger gripper.

Learned skills: ``pour`` (4 context + 4 control), ``scoop`` (2 + 7) and ``push`` (2 + 4),
with the seed paper's parameterisations and score functions. See :mod:`.backend`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ltamp_cli.backends.box2d.backend import Kitchen2DBackend
    from ltamp_cli.backends.box2d.executor import Kitchen2DExecutor


def make_backend(**options: Any) -> Kitchen2DBackend:
    """Create a :class:`~ltamp_cli.backends.box2d.backend.Kitchen2DBackend` (Box2D is
    imported only here, so listing backends stays cheap)."""
    from ltamp_cli.backends.box2d.backend import Kitchen2DBackend

    return Kitchen2DBackend(**options)


def make_executor(**options: Any) -> Kitchen2DExecutor:
    """Create the kitchen2d plan executor (see :mod:`ltamp_cli.backends.execution`)."""
    from ltamp_cli.backends.box2d.executor import Kitchen2DExecutor

    return Kitchen2DExecutor(**options)


__all__ = ["make_backend", "make_executor"]
