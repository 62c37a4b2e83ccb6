"""Bindings of the fluent symbolic kitchen: slots for placements, a state-dependent motion.

A region has a number of slots in a row (``world["slots"]``); a pose is a slot's name, so two
objects collide exactly when they use one slot. A configuration is where the arm is
(``above:<region>/<index>``, ``under:<faucet>`` or ``home``). ``plan-motion`` is a
``:fluents`` stream: it is given the poses of the objects standing (``AtPose``) and the grasp
held (``AtGrasp``) in the state of the move. The arm sweeps low over the slots between its
two ends, so while it carries a tall object (``world["tall"]``) it cannot pass over a slot
where another tall object stands (it fails there; the planner then moves that object first
or goes another way).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from ltamp_cli.planner.streams import Binding, StreamInfo

EAGER = StreamInfo(eager=True)


def slot_of(conf: str) -> tuple[str, int] | None:
    """The (region, index) a configuration is above, or ``None`` (faucet, home)."""
    if not conf.startswith("above:"):
        return None
    region, _, index = conf[len("above:"):].partition("/")
    return region, int(index)


def swept_slots(start: str, goal: str) -> list[tuple[str, int]]:
    """Slots strictly between two configurations above the same region (none otherwise)."""
    first, last = slot_of(start), slot_of(goal)
    if first is None or last is None or first[0] != last[0]:
        return []
    low, high = sorted((first[1], last[1]))
    return [(first[0], index) for index in range(low + 1, high)]


def make_streams(world: Mapping[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    slots: dict[str, int] = {str(k): int(v) for k, v in world["slots"].items()}
    tool_skills: dict[str, list[str]] = {str(k): list(v) for k, v in
                                         world.get("tool_targets", {}).items()}
    tall: set[str] = set(world.get("tall", []))

    def sample_pose(obj: str, region: str) -> Iterator[tuple[str]]:
        # Every slot once, in a seeded random order (knows nothing of other objects).
        for index in rng.permutation(slots.get(region, 0)):
            yield (f"{region}/{int(index)}",)

    def sample_grasp(obj: str) -> tuple[str]:
        return (f"grasp:{obj}",)

    def inverse_kinematics(obj: str, pose: str, grasp: str) -> tuple[str]:
        return (f"above:{pose}",)

    def fill_conf(faucet: str, cup: str, grasp: str) -> tuple[str]:
        return (f"under:{faucet}",)

    def skill_conf(tool: str, grasp: str, target: str, pose: str) -> tuple[str] | None:
        allowed = tool_skills.get(tool.split(":")[-1])
        if allowed is not None and target not in allowed:
            return None  # this tool is not used on that container
        return (f"above:{pose}",)

    def plan_motion(start: str, goal: str, fluents: Sequence[tuple[Any, ...]] = ()
                    ) -> tuple[str] | None:
        if start == goal:
            return None
        held = next((fact[1] for fact in fluents if fact[0].lower() == "atgrasp"), None)
        if held in tall:
            standing = {tuple(str(fact[2]).split("/")) for fact in fluents
                        if fact[0].lower() == "atpose" and fact[1] in tall}
            for region, index in swept_slots(start, goal):
                if (region, str(index)) in standing:
                    return None  # the carried object would hit a tall one on the way
        return (f"{start}->{goal}" + (f" carrying {held}" if held else ""),)

    def test_cfree(o1: str, p1: str, o2: str, p2: str) -> bool:
        return p1 != p2

    return {
        "sample-pose": sample_pose,
        "sample-grasp": Binding(sample_grasp, EAGER),
        "inverse-kinematics": Binding(inverse_kinematics, EAGER),
        "fill-conf": Binding(fill_conf, EAGER),
        "skill-conf": Binding(skill_conf, EAGER),
        "plan-motion": plan_motion,  # a :fluents stream: called per state, never eagerly
        "test-cfree": Binding(test_cfree, EAGER),
    }
