"""Plain samplers for the hidden-stack domain (issue #19's hidden suite).

Placements on the table are uniform in a region; placements on a block put the new block's
centre uniformly over the lower block's top; neither knows where other blocks are.
Collisions between 2D boxes are found only by ``test-cfree`` (through the domain's negated
``UnsafePose``); a block resting exactly on another does not collide with it.

Values: a pose is the block's bottom centre ``(x, y)`` (m); the grasp is the gripper's offset
from the pose ``(0, height)``; a configuration is the gripper position ``(x, y)``; a
trajectory is a tuple of configurations (up to the carry height, across, down).

``world``: ``regions {name: [lo, hi]}``, ``blocks {name: {width, height}}`` (default 2 x 2),
``carry_height`` (m, above every tower).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np

Pose = tuple[float, float]
Conf = tuple[float, float]
MOVE_COST = 10.0
DEFAULT_SIZE = 2.0
# Heights are sums of a few decimals: resting on a block is not an overlap.
OVERLAP_TOLERANCE = 1e-9


def plain_streams(world: Mapping[str, Any], rng: np.random.Generator
                  ) -> dict[str, tuple[str, Callable[..., Any]]]:
    """``{stream name: (kind, callable)}``, kinds as in ``robots/streams.py``."""
    regions = {name: (float(lo), float(hi)) for name, (lo, hi) in world["regions"].items()}
    blocks: Mapping[str, Mapping[str, float]] = world.get("blocks") or {}
    carry = float(world.get("carry_height", 10.0))

    def width(block: str) -> float:
        return float(blocks.get(block, {}).get("width", DEFAULT_SIZE))

    def height(block: str) -> float:
        return float(blocks.get(block, {}).get("height", DEFAULT_SIZE))

    def sample_pose(block: str, region: str) -> Iterator[tuple[Pose]]:
        low, high = regions[region]
        half = width(block) / 2.0
        if high - low < 2 * half:
            return
        while True:
            yield ((float(rng.uniform(low + half, high - half)), 0.0),)

    def sample_stack(block: str, below: str, below_pose: Pose) -> Iterator[tuple[Pose]]:
        if block == below:
            return
        half = width(below) / 2.0
        top = below_pose[1] + height(below)
        while True:
            yield ((float(below_pose[0] + rng.uniform(-half, half)), top),)

    def sample_grasp(block: str) -> tuple[Conf]:
        return ((0.0, height(block)),)

    def inverse_kinematics(block: str, pose: Pose, grasp: Conf) -> tuple[Conf]:
        return ((pose[0] + grasp[0], pose[1] + grasp[1]),)

    def plan_motion(start: Conf, goal: Conf) -> tuple[tuple[Conf, ...]]:
        return ((start, (start[0], carry), (goal[0], carry), goal),)

    def test_cfree(block1: str, pose1: Pose, block2: str, pose2: Pose) -> bool:
        apart_x = abs(pose1[0] - pose2[0]) > (width(block1) + width(block2)) / 2.0
        apart_y = (pose1[1] + height(block1) <= pose2[1] + OVERLAP_TOLERANCE
                   or pose2[1] + height(block2) <= pose1[1] + OVERLAP_TOLERANCE)
        return apart_x or apart_y

    def distance(start: Conf, goal: Conf) -> float:
        return MOVE_COST + abs(carry - start[1]) + abs(start[0] - goal[0]) + abs(carry - goal[1])

    return {
        "sample-pose": ("gen", sample_pose),
        "sample-stack": ("gen", sample_stack),
        "sample-grasp": ("fn", sample_grasp),
        "inverse-kinematics": ("fn", inverse_kinematics),
        "plan-motion": ("fn", plan_motion),
        "test-cfree": ("test", test_cfree),
        "distance": ("function", distance),
    }


def make_streams(world: Mapping[str, Any], rng: np.random.Generator
                 ) -> dict[str, Callable[..., Any]]:
    """ltamp's bindings: the plain callables, no planner hints."""
    return {name: fn for name, (_, fn) in plain_streams(world, rng).items()}
