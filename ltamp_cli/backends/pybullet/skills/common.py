"""Pieces shared by the Kitchen3D skills: latent physical properties, kinematic tool motion,
and the geometric pre-check of a tool path against a bowl."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ltamp_cli.backends.kitchenware_geometry import (
    KitchenwareGeometry,
    VesselDims,
    check_points,
    points_in_vessel_wall,
)
from ltamp_cli.backends.pybullet.kitchenware import KitchenwareBody
from ltamp_cli.backends.pybullet.paths import PosePath, velocities
from ltamp_cli.backends.pybullet.world import PhysicsWorld

StepCallback = Callable[[int], None]

#: Point spacing (m) on the tool surface for the collision pre-check.
CHECK_SPACING_M = 0.004


def truncated_normal(
    rng: np.random.Generator, mean: float, std: float, low: float, high: float
) -> float:
    """One draw of ``N(mean, std²)`` restricted to ``[low, high]`` (by rejection)."""
    for _ in range(1000):
        value = rng.normal(mean, std)
        if low <= value <= high:
            return float(value)
    return float(np.clip(mean, low, high))


@dataclass(frozen=True)
class PathCheck:
    """Outcome of the pre-check: ``valid`` and the index of the first colliding pose."""

    valid: bool
    first_hit: int = -1
    reason: str = ""


def check_tool_path(
    tool: KitchenwareGeometry,
    path: PosePath,
    bowl: VesselDims,
    spacing: float = CHECK_SPACING_M,
    tool_points: tuple[np.ndarray, float] | None = None,
) -> PathCheck:
    """Does ``tool`` moved along ``path`` stay clear of ``bowl`` (at the origin) and the table?

    Conservative: points of the tool (:func:`check_points`, about ``spacing`` apart), on
    poses resampled so no point moves more than ``spacing`` between them, must stay
    ``spacing`` (plus the points' own margin) away from the bowl's material and above the
    table. ``tool_points`` caches ``check_points(tool, spacing)`` across a batch.
    """
    points, own_margin = check_points(tool, spacing) if tool_points is None else tool_points
    dense = path.densify(points, max_move=spacing)
    chunk = max(1, 200_000 // max(len(points), 1))
    for start in range(0, len(dense), chunk):
        part = PosePath(
            dense.positions[start : start + chunk], dense.quaternions[start : start + chunk]
        )
        world = part.transform(points)  # (k, m, 3)
        below = (world[..., 2] < own_margin).any(axis=1)
        hits = points_in_vessel_wall(world.reshape(-1, 3), bowl, margin=spacing + own_margin)
        hits = hits.reshape(world.shape[:2]).any(axis=1)
        bad = np.flatnonzero(below | hits)
        if bad.size:
            index = int(bad[0])
            reason = "tool path hits the bowl" if hits[index] else "tool path goes below the table"
            return PathCheck(False, start + index, reason)
    return PathCheck(True)


def follow_path(
    world: PhysicsWorld,
    tool: KitchenwareBody,
    path: PosePath,
    on_step: StepCallback | None = None,
    step_offset: int = 0,
) -> int:
    """Move ``tool`` kinematically through ``path`` (one pose per simulation step), giving it
    the velocity that reaches the next pose so contacts push particles realistically.
    Returns the number of steps taken."""
    linear, angular = velocities(path, world.config.time_step)
    for i in range(len(path)):
        tool.set_pose(path.positions[i], path.quaternions[i], linear[i], angular[i])
        world.step()
        if on_step is not None:
            on_step(step_offset + i)
    tool.set_pose(path.positions[-1], path.quaternions[-1])
    return len(path)


def hold(
    world: PhysicsWorld,
    tool: KitchenwareBody,
    position: np.ndarray,
    quaternion: np.ndarray,
    steps: int,
    on_step: StepCallback | None = None,
    step_offset: int = 0,
) -> int:
    """Keep ``tool`` still at a pose for ``steps`` simulation steps."""
    for i in range(steps):
        tool.set_pose(position, quaternion)
        world.step()
        if on_step is not None:
            on_step(step_offset + i)
    tool.set_pose(position, quaternion)
    return steps
