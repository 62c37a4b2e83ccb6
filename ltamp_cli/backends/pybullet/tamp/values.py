"""Planner values of the Kitchen3D streams (hashable where two equal values must be one object).

* pose: ``(x, y)`` tuple, metres (the object's base centre on the table top, upright);
* grasp: ``(kind, index)`` tuple into the object's grasp list (:mod:`.grasping`);
* :class:`ArmConf`: one arm's joint configuration;
* :class:`ArmPath`: a joint-space path of one arm (compared by identity: every path the
  streams make is a new object).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

XY = tuple[float, float]
GraspValue = tuple[str, int]


@dataclass(frozen=True)
class ArmConf:
    """``q``: the 7 joint angles (radians) of arm ``arm`` (0 at ``-x``, 1 at ``+x``)."""

    arm: int
    q: tuple[float, ...]

    @staticmethod
    def of(arm: int, q: np.ndarray) -> ArmConf:
        return ArmConf(int(arm), tuple(round(float(v), 6) for v in np.asarray(q).reshape(-1)))

    @property
    def array(self) -> np.ndarray:
        return np.asarray(self.q, dtype=float)

    def to_json(self) -> dict[str, Any]:
        return {"arm": self.arm, "q": list(self.q)}


def as_conf(value: Any) -> ArmConf:
    """An :class:`ArmConf` from a planner value: itself, or a problem file's
    ``{arm: 0, q: [7 angles]}``."""
    if isinstance(value, ArmConf):
        return value
    if isinstance(value, dict) and set(value) == {"arm", "q"} and len(value["q"]) == 7:
        return ArmConf.of(int(value["arm"]), np.asarray(value["q"], dtype=float))
    raise ValueError(f"not an arm configuration: {value!r} (expected {{arm: 0, q: [7 angles]}})")


@dataclass(frozen=True, eq=False)
class ArmPath:
    """Configurations ``(n, 7)`` of arm ``arm``; ``held`` is ``(object, grasp)`` when it
    carries an object; ``touching`` names the object the hand closes on at the path's end
    (pick/place approaches), which collision tests against that object ignore; ``target``
    names the object a held tool works in (the bowl poured or scooped into), which the
    tool may touch (its skill's own geometric pre-check has validated that) but the arm
    may not. ``kind``: ``free``, ``holding``, ``approach``, ``pour``, ``scoop``, ``dump``,
    ``stir``, ``push``. ``finger_gap`` (m): the opening the hand executes the path with and
    the planner's collision tests give it (a push: open across a round object's line, else
    closed); ``None``: the planning world's default hand, fully open (the widest sweep)."""

    arm: int
    configurations: np.ndarray
    kind: str
    held: tuple[str, GraspValue] | None = None
    touching: str | None = None
    target: str | None = None
    finger_gap: float | None = None

    @property
    def start(self) -> ArmConf:
        return ArmConf.of(self.arm, self.configurations[0])

    @property
    def end(self) -> ArmConf:
        return ArmConf.of(self.arm, self.configurations[-1])

    def to_json(self) -> dict[str, Any]:
        return {"kind": self.kind, "arm": self.arm, "waypoints": len(self.configurations),
                "held": None if self.held is None else self.held[0]}
