"""Plain samplers for the tamp2d-uniform domain: nothing here knows where other blocks are.

The placement sampler draws block centres uniformly from the region (independently of every
other block and of earlier samples), kinematics and motions are closed-form, and collisions
are found only by ``test-cfree`` through the domain's negated ``UnsafePose`` predicate, as in
PDDLStream's continuous TAMP example. It is the kind of sampler a user writes first, so the
planner, not the sampler, has to cope with placements that collide.

Values: a pose is the block centre's x on the table (m, float); a grasp is the gripper's
offset from the block centre ``(dx, dy)``; a configuration is the gripper position ``(x, y)``;
a trajectory is a tuple of configurations (up to the carry height, across, down).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np

from ltamp_cli.planner.streams import Binding, StreamInfo

Conf = tuple[float, float]
# Closed-form and decisive: evaluated for real as soon as their inputs exist.
EAGER = StreamInfo(eager=True)
# Fixed cost of every move on top of its path length (PDDLStream's MOVE_COST).
MOVE_COST = 10.0
DEFAULT_BLOCK_WIDTH = 2.0
DEFAULT_BLOCK_HEIGHT = 2.0


def make_streams(world: Mapping[str, Any], rng: np.random.Generator
                 ) -> dict[str, Callable | Binding]:
    """Bindings of every stream of ``stream.pddl`` for ``world`` (regions ``{name: [lo,
    hi]}``, optional ``blocks`` ``{name: {width, height}}`` and ``carry_height``, m)."""
    regions: dict[str, tuple[float, float]] = {
        name: (float(lo), float(hi)) for name, (lo, hi) in world["regions"].items()}
    blocks: Mapping[str, Mapping[str, float]] = world.get("blocks") or {}
    carry_height = float(world.get("carry_height", 5.0))

    def width(block: str) -> float:
        return float(blocks.get(block, {}).get("width", DEFAULT_BLOCK_WIDTH))

    def height(block: str) -> float:
        return float(blocks.get(block, {}).get("height", DEFAULT_BLOCK_HEIGHT))

    def sample_pose(block: str, region: str) -> Iterator[tuple[float]]:
        low, high = regions[region]
        half = width(block) / 2.0
        if high - low < 2 * half:
            return
        while True:
            yield (float(rng.uniform(low + half, high - half)),)

    def sample_grasp(block: str) -> tuple[tuple[float, float]]:
        return ((0.0, height(block)),)  # from above, centred

    def inverse_kinematics(block: str, pose: float, grasp: tuple[float, float]
                           ) -> tuple[Conf]:
        return ((pose + grasp[0], grasp[1]),)

    def plan_motion(start: Conf, goal: Conf) -> tuple[tuple[Conf, ...]]:
        return ((start, (start[0], carry_height), (goal[0], carry_height), goal),)

    def test_cfree(block1: str, pose1: float, block2: str, pose2: float) -> bool:
        # Touching counts as a collision.
        return abs(pose1 - pose2) > (width(block1) + width(block2)) / 2.0

    def distance(start: Conf, goal: Conf) -> float:
        path = (carry_height - start[1]) + abs(start[0] - goal[0]) + (carry_height - goal[1])
        return MOVE_COST + abs(path)

    return {
        "sample-pose": sample_pose,
        "sample-grasp": Binding(sample_grasp, EAGER),
        "inverse-kinematics": Binding(inverse_kinematics, EAGER),
        "plan-motion": plan_motion,
        "test-cfree": Binding(test_cfree, EAGER),
        "distance": distance,
    }
