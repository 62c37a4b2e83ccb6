"""Kitchen2D: a 2D kitchen on Box2D with a free-flying two-finger gripper.

Learned skills: ``pour`` (4 context + 4 control), ``scoop`` (2 + 7) and ``push`` (2 + 4),
with the seed paper's parameterisations and score functions. See :mod:`.backend`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ltamp_cli.backends.box2d.backend import Kitchen2DBackend


def make_backend(**options: Any) -> Kitchen2DBackend:
    """Create a :class:`~ltamp_cli.backends.box2d.backend.Kitchen2DBackend` (Box2D is
    imported only here, so listing backends stays cheap)."""
    from ltamp_cli.backends.box2d.backend import Kitchen2DBackend

    return Kitchen2DBackend(**options)


__all__ = ["make_backend"]
