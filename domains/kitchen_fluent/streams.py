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

import importlib.util
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np


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


def _symbolic_kitchen() -> ModuleType:
    """The plain symbolic kitchen's bindings, whose closed-form streams this kitchen shares
    (loaded from its file: bindings modules are files, not an installed package)."""
    path = Path(__file__).resolve().parent.parent / "kitchen_symbolic" / "streams.py"
    spec = importlib.util.spec_from_file_location("kitchen_symbolic_streams", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def make_streams(world: Mapping[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    """The symbolic kitchen's grasps, kinematics, skill configurations and collision test,
    with a plain slot sampler and the state-dependent motion stream."""
    slots: dict[str, int] = {str(k): int(v) for k, v in world["slots"].items()}
    tall: set[str] = set(world.get("tall", []))

    def sample_pose(obj: str, region: str) -> Iterator[tuple[str]]:
        # Every slot once, in a seeded random order (knows nothing of other objects).
        for index in rng.permutation(slots.get(region, 0)):
            yield (f"{region}/{int(index)}",)

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

    streams = dict(_symbolic_kitchen().make_streams(world, rng))
    streams["sample-pose"] = sample_pose
    streams["plan-motion"] = plan_motion  # a :fluents stream: called per state, not eagerly
    return streams
