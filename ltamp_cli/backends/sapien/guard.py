"""The divergence guard's view of a SAPIEN world: its PhysX rigid dynamic bodies."""

from __future__ import annotations

from typing import Any

from ltamp_cli.backends.sanity import BodyGuard, BodyState, StateLimits
from ltamp_cli.backends.sapien.world import SapienWorld


def sapien_guard(
    world: SapienWorld, every: int = 20, limits: StateLimits | None = None
) -> BodyGuard[Any]:
    """A :class:`~ltamp_cli.backends.sanity.BodyGuard` over the dynamic bodies of ``world``'s
    current scene (positions in m, velocities in m/s); the scene is looked up on every
    refresh because :meth:`SapienWorld.reset` replaces it."""

    def bodies() -> list[Any]:
        return list(world.scene.physx_system.get_rigid_dynamic_components())

    def state(body: Any) -> BodyState:
        return tuple(body.entity_pose.p), tuple(body.linear_velocity)

    def name(body: Any) -> str:
        return str(body.entity.name or body.name or "body")

    return BodyGuard(bodies, state, name, every, limits)
