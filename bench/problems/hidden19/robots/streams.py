"""Plain samplers for the hidden-robots domain (issue #19's hidden suite).

Nothing here knows where other blocks are: placements are uniform in a region, grasps are
uniform offsets along the block's top, inverse kinematics is closed form and fails outside
the robot's reach, motions are straight (up to the carry height, across, down), collisions
are found only by ``test-cfree`` through the domain's negated ``UnsafePose``.

Values: a pose is the block centre's x on the table (m, float); a grasp is the gripper's
offset from the block's centre ``(dx, dy)``; a configuration is the gripper position
``(x, y)``; a trajectory is a tuple of configurations.

``world``: ``regions {name: [lo, hi]}``, ``blocks {name: {width, height}}`` (default 2 x 2,
obstacles included), ``robots {name: [lo, hi]}`` (the x interval the gripper reaches),
``carry_height`` (m).

:func:`plain_streams` gives the raw callables with their kinds, so the same samplers can be
handed to PDDLStream (``bench/planner_hidden.py``); :func:`make_streams` is ltamp's factory.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np

Conf = tuple[float, float]
MOVE_COST = 10.0  # fixed cost of a move on top of its path length (PDDLStream's MOVE_COST)
DEFAULT_SIZE = 2.0


def plain_streams(world: Mapping[str, Any], rng: np.random.Generator
                  ) -> dict[str, tuple[str, Callable[..., Any]]]:
    """``{stream name: (kind, callable)}`` with kind ``gen`` (a generator of output tuples),
    ``fn`` (one output tuple or ``None``), ``test`` (bool) or ``function`` (float)."""
    regions = {name: (float(lo), float(hi)) for name, (lo, hi) in world["regions"].items()}
    robots = {name: (float(lo), float(hi)) for name, (lo, hi) in world["robots"].items()}
    blocks: Mapping[str, Mapping[str, float]] = world.get("blocks") or {}
    carry = float(world.get("carry_height", 5.0))

    def width(block: str) -> float:
        return float(blocks.get(block, {}).get("width", DEFAULT_SIZE))

    def height(block: str) -> float:
        return float(blocks.get(block, {}).get("height", DEFAULT_SIZE))

    def sample_pose(block: str, region: str) -> Iterator[tuple[float]]:
        low, high = regions[region]
        half = width(block) / 2.0
        if high - low < 2 * half:
            return
        while True:
            yield (float(rng.uniform(low + half, high - half)),)

    def test_region(block: str, pose: float, region: str) -> bool:
        low, high = regions[region]
        half = width(block) / 2.0
        return low + half <= pose <= high - half

    def sample_grasp(block: str) -> Iterator[tuple[Conf]]:
        quarter = width(block) / 4.0
        while True:
            yield ((float(rng.uniform(-quarter, quarter)), height(block)),)

    def inverse_kinematics(robot: str, block: str, pose: float, grasp: Conf
                           ) -> tuple[Conf] | None:
        low, high = robots[robot]
        x = pose + grasp[0]
        return ((x, grasp[1]),) if low <= x <= high else None

    def plan_motion(robot: str, start: Conf, goal: Conf) -> tuple[tuple[Conf, ...]]:
        return ((start, (start[0], carry), (goal[0], carry), goal),)

    def test_cfree(block1: str, pose1: float, block2: str, pose2: float) -> bool:
        return abs(pose1 - pose2) > (width(block1) + width(block2)) / 2.0  # touching collides

    def distance(robot: str, start: Conf, goal: Conf) -> float:
        return MOVE_COST + (carry - start[1]) + abs(start[0] - goal[0]) + (carry - goal[1])

    return {
        "sample-pose": ("gen", sample_pose),
        "test-region": ("test", test_region),
        "sample-grasp": ("gen", sample_grasp),
        "inverse-kinematics": ("fn", inverse_kinematics),
        "plan-motion": ("fn", plan_motion),
        "test-cfree": ("test", test_cfree),
        "distance": ("function", distance),
    }


def make_streams(world: Mapping[str, Any], rng: np.random.Generator
                 ) -> dict[str, Callable[..., Any]]:
    """ltamp's bindings: the plain callables, no planner hints."""
    return {name: fn for name, (_, fn) in plain_streams(world, rng).items()}
