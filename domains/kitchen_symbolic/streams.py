"""Bindings of the symbolic kitchen: discrete slots stand in for continuous placements.

A region has a number of slots (``world["slots"]``); a pose is the slot's name, shared by
every object that can stand there, so two objects collide exactly when they use one slot.
A configuration is where the arm is (``above:<slot>`` or ``under:<faucet>``) and a motion
between two configurations is their ordered pair.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np

from ltamp_cli.planner.streams import Binding, StreamInfo

EAGER = StreamInfo(eager=True)


def make_streams(world: Mapping[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    slots: dict[str, int] = {str(k): int(v) for k, v in world["slots"].items()}
    tool_skills: dict[str, list[str]] = {str(k): list(v) for k, v in
                                         world.get("tool_targets", {}).items()}

    # Slots seen as stream inputs before this sampler made them are where the problem put
    # an object: most stay taken for much of the plan, so they are offered last.
    sampled: set[str] = set()
    given: set[str] = set()

    def seen(pose: str) -> None:
        if pose not in sampled:
            given.add(pose)

    def sample_pose(obj: str, region: str) -> Iterator[tuple[str]]:
        # Slots in a seeded random order, so different seeds try different placements.
        left = [f"{region}/{int(index)}" for index in rng.permutation(slots.get(region, 0))]
        while left:
            pose = next((p for p in left if p not in given), left[0])
            left.remove(pose)
            sampled.add(pose)
            yield (pose,)

    def sample_grasp(obj: str) -> tuple[str]:
        return (f"grasp:{obj}",)

    def inverse_kinematics(obj: str, pose: str, grasp: str) -> tuple[str]:
        seen(pose)
        return (f"above:{pose}",)

    def fill_conf(faucet: str, cup: str, grasp: str) -> tuple[str]:
        return (f"under:{faucet}",)

    def skill_conf(tool: str, grasp: str, target: str, pose: str) -> tuple[str] | None:
        allowed = tool_skills.get(tool.split(":")[-1])
        if allowed is not None and target not in allowed:
            return None  # this tool is not used on that container
        return (f"above:{pose}",)

    def plan_motion(q1: str, q2: str) -> tuple[str] | None:
        return None if q1 == q2 else (f"{q1}->{q2}",)

    def test_cfree(o1: str, p1: str, o2: str, p2: str) -> bool:
        seen(p1)
        seen(p2)
        return p1 != p2

    # Cheap closed-form streams are evaluated eagerly (for real) rather than optimistically.
    return {
        "sample-pose": sample_pose,
        "sample-grasp": Binding(sample_grasp, EAGER),
        "inverse-kinematics": Binding(inverse_kinematics, EAGER),
        "fill-conf": Binding(fill_conf, EAGER),
        "skill-conf": Binding(skill_conf, EAGER),
        "plan-motion": Binding(plan_motion, EAGER),
        "test-cfree": Binding(test_cfree, EAGER),
    }
