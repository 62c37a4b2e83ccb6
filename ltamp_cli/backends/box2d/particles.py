"""Particles (water, coffee, sugar): small frictionless circles, and where they are.

Field facts: radius 0.05, density 0.01, friction 0 in the earlier Kitchen2D.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from Box2D import b2

from ltamp_cli.backends.box2d.world import Kitchen


@dataclass(frozen=True)
class ParticleSpec:
    """Material of one particle kind (radius in world units)."""

    radius: float = 0.05
    density: float = 0.01
    friction: float = 0.0
    color: tuple[int, int, int] = (40, 90, 230)
    material: str = ""


def hex_grid(
    x0: float, x1: float, y0: float, n: int, radius: float, rng: np.random.Generator
) -> np.ndarray:
    """``n`` centres packed in rows from ``y0`` upward between ``x0`` and ``x1``.

    Rows are hexagonally offset with a spacing of ``2.02 * radius`` so no two circles
    overlap; a small seeded jitter makes different seeds give different trials.
    Returns shape ``(n, 2)``; raises ``ValueError`` if not even one column fits.
    """
    pitch = 2.02 * radius
    width = x1 - x0 - 2 * radius
    per_row = math.floor(width / pitch) + 1
    if width < 0 or per_row < 1:
        raise ValueError("region too narrow for one particle")
    rows = []
    row = 0
    while sum(len(r) for r in rows) < n:
        offset = (pitch / 2) if row % 2 else 0.0
        count = per_row - (1 if row % 2 and offset + (per_row - 1) * pitch > width else 0)
        xs = x0 + radius + offset + pitch * np.arange(count)
        ys = np.full(count, y0 + radius + row * pitch * math.sqrt(3) / 2)
        rows.append(np.stack([xs, ys], axis=1))
        row += 1
    points = np.concatenate(rows)[:n]
    jitter = rng.uniform(-0.004, 0.004, size=points.shape) * radius / 0.05
    return points + jitter


def add_particles(kitchen: Kitchen, points: np.ndarray, spec: ParticleSpec) -> list[b2.body]:
    """Add one dynamic circle per row of ``points`` (shape ``(n, 2)``) to the kitchen."""
    bodies = []
    for x, y in points:
        body = kitchen.world.CreateDynamicBody(position=(float(x), float(y)))
        body.CreateCircleFixture(radius=spec.radius, density=spec.density, friction=spec.friction)
        body.userData = {
            "name": "particle",
            "color": spec.color,
            "radius": spec.radius,
            "material": spec.material,
        }
        bodies.append(body)
    kitchen.particles.extend(bodies)
    return bodies


def to_local(points: np.ndarray, body: b2.body) -> np.ndarray:
    """Express world ``points`` (``(n, 2)``) in ``body``'s frame."""
    c, s = math.cos(body.angle), math.sin(body.angle)
    d = points - np.array(tuple(body.position))
    return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)


def inside_box(
    points: np.ndarray, body: b2.body, x0: float, x1: float, y0: float, y1: float
) -> np.ndarray:
    """Which ``points`` lie in the rectangle ``[x0, x1] x [y0, y1]`` of ``body``'s frame."""
    local = to_local(points, body)
    return (local[:, 0] >= x0) & (local[:, 0] <= x1) & (local[:, 1] >= y0) & (local[:, 1] <= y1)
