"""Python bindings of the tamp2d streams: real 2D samplers, kinematics and collision tests.

Values: a pose is the block centre's x on the table (float); a grasp is the gripper's offset
from the block centre ``(dx, dy)``; a configuration is the gripper position ``(x, y)``; a
trajectory is a tuple of configurations (up, across at the transit height, down).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np

from ltamp_cli.planner.streams import Binding, StreamInfo

EAGER = StreamInfo(eager=True)
# Uniform candidates per placement sample (best-candidate sampling, see sample_pose).
BEST_CANDIDATES = 8
# Placements per generator that prefer spots clear of other blocks' known poses; later ones
# spread by best-candidate alone, which then fills the avoided spots first (denseness).
CLEAR_PLACEMENTS = 3

Conf = tuple[float, float]


def make_streams(world: Mapping[str, Any], rng: np.random.Generator) -> dict[str, Callable]:
    regions: dict[str, tuple[float, float]] = {
        name: (float(lo), float(hi)) for name, (lo, hi) in world["regions"].items()}
    blocks: dict[str, dict[str, float]] = world["blocks"]
    reach = float(world.get("reach", 20.0))
    transit_height = float(world.get("transit_height", 5.0))

    def width(block: str) -> float:
        return float(blocks[block]["width"])

    def height(block: str) -> float:
        return float(blocks[block].get("height", 1.0))

    # Every pose the streams have seen per block: given ones (seen as inputs) and sampled
    # ones. A placement prefers spots clear of other blocks' known poses, as TAMP placement
    # samplers keep clear of known obstacles; a preference, not a rule, so it stays dense.
    known: dict[str, set[float]] = {}

    def note(block: str, pose: float) -> None:
        known.setdefault(block, set()).add(pose)

    def overlaps(block: str, candidates: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """How many known poses of other blocks each candidate pose collides with, and the
        total overlap (m), both ``(n,)``. Where every spot collides with something (a goal
        region holding another block), the least-overlapping one leaves the most room."""
        count = np.zeros(len(candidates), dtype=np.int64)
        length = np.zeros(len(candidates))
        for other, poses in known.items():
            if other == block or not poses:
                continue
            clearance = (width(block) + width(other)) / 2.0
            others = np.fromiter(poses, dtype=float, count=len(poses))
            depth = np.clip(clearance - np.abs(candidates[:, None] - others[None, :]), 0.0, None)
            count += (depth > 0).sum(axis=1)
            length += depth.sum(axis=1)
        return count, length

    def sample_pose(block: str, region: str) -> Iterator[tuple[float]]:
        low, high = regions[region]
        half = width(block) / 2.0
        if high - low < 2 * half:
            return
        # Mitchell's best-candidate sampling: each placement is the one of a few uniform
        # candidates farthest from this generator's earlier placements, so the first
        # samples spread over the region (two blocks fit side by side after two samples,
        # not after four or five) while the sequence stays random and dense. Candidates
        # clear of other blocks' known poses come first.
        placed: list[float] = []
        while True:
            candidates = rng.uniform(low + half, high - half, size=BEST_CANDIDATES)
            if placed:
                gaps = np.abs(candidates[:, None] - np.asarray(placed)[None, :]).min(axis=1)
            else:
                gaps = np.zeros(len(candidates))
            if len(placed) < CLEAR_PLACEMENTS:
                count, length = overlaps(block, candidates)
                # Fewest collisions, then least overlap, then the widest gap.
                order = np.lexsort((-gaps, length, count))
            else:
                order = np.argsort(-gaps, kind="stable")
            choice = round(float(candidates[order[0]]), 4)
            placed.append(choice)
            note(block, choice)
            yield (choice,)

    def sample_grasp(block: str) -> tuple[tuple[float, float]]:
        # The gripper closes on the block from above, centred: one grasp per block keeps the
        # number of configurations (and of motions between them) small.
        return ((0.0, height(block)),)

    def inverse_kinematics(block: str, pose: float, grasp: tuple[float, float]
                           ) -> tuple[Conf] | None:
        note(block, pose)
        conf = (round(pose + grasp[0], 4), round(grasp[1], 4))
        if abs(conf[0]) > reach:
            return None  # out of the gripper's reach
        return (conf,)

    def plan_motion(start: Conf, goal: Conf) -> tuple[tuple[Conf, ...]] | None:
        if start == goal:
            return None
        above_start = (start[0], transit_height)
        above_goal = (goal[0], transit_height)
        return ((start, above_start, above_goal, goal),)

    def test_cfree(block1: str, pose1: float, block2: str, pose2: float) -> bool:
        note(block1, pose1)
        note(block2, pose2)
        return abs(pose1 - pose2) >= (width(block1) + width(block2)) / 2.0

    def distance(q1: Conf, q2: Conf) -> float:
        # Path length of the transit motion: up, across, down.
        return round((transit_height - q1[1]) + abs(q1[0] - q2[0]) + (transit_height - q2[1])
                     + 1.0, 4)

    # Cheap closed-form streams are evaluated eagerly (for real) rather than optimistically.
    return {
        "sample-pose": sample_pose,
        "sample-grasp": Binding(sample_grasp, EAGER),
        "inverse-kinematics": Binding(inverse_kinematics, EAGER),
        "plan-motion": Binding(plan_motion, EAGER),
        # Cheap and decisive: evaluate as soon as its inputs exist (PDDLStream's eager).
        "test-cfree": Binding(test_cfree, EAGER),
        "distance": Binding(distance, EAGER),
    }
