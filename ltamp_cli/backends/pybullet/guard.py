"""The divergence guard's view of a PyBullet world: every body's base position and velocity."""

from __future__ import annotations

import pybullet as p

from ltamp_cli.backends.sanity import BodyGuard, BodyState, StateLimits


def bullet_guard(client: int, every: int = 20, limits: StateLimits | None = None) -> BodyGuard[int]:
    """A :class:`~ltamp_cli.backends.sanity.BodyGuard` over the bodies of PyBullet ``client``
    (positions in m, velocities in m/s)."""

    def bodies() -> list[int]:
        count = p.getNumBodies(physicsClientId=client)
        return [p.getBodyUniqueId(i, physicsClientId=client) for i in range(count)]

    def state(body: int) -> BodyState:
        position = p.getBasePositionAndOrientation(body, physicsClientId=client)[0]
        return position, p.getBaseVelocity(body, physicsClientId=client)[0]

    def name(body: int) -> str:
        info = p.getBodyInfo(body, physicsClientId=client)
        labels = [raw.decode(errors="replace") for raw in info]
        label = next((text for text in reversed(labels) if text), "")
        return f"body {body} ({label})" if label else f"body {body}"

    return BodyGuard(bodies, state, name, every, limits)
