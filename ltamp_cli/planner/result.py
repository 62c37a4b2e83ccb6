"""What a planner run returns."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

SOLVED, INFEASIBLE, TIMEOUT = "solved", "infeasible", "timeout"


@dataclass(frozen=True)
class PlanStep:
    """One action of a plan: its name, argument objects and their Python values."""

    name: str
    args: tuple[str, ...]
    values: tuple[Any, ...]
    cost: float

    def __str__(self) -> str:
        return "(" + " ".join((self.name, *self.args)) + ")"


@dataclass(frozen=True)
class StreamResult:
    """One stream output used by the plan: ``stream(inputs) -> outputs`` certifying facts."""

    stream: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    certified: tuple[tuple[str, ...], ...]
    # Facts a call certified beyond the stream's :certified ones (wild outputs): known only
    # from that call, so a validator cannot derive them from the declaration.
    wild: bool = False


@dataclass
class Certificate:
    """Why the plan is valid: the facts it relies on and the stream results behind them."""

    preimage: list[tuple[str, ...]] = field(default_factory=list)
    stream_results: list[StreamResult] = field(default_factory=list)
    facts: list[tuple[str, ...]] = field(default_factory=list)  # all facts known at the end


@dataclass
class PlanResult:
    status: str
    plan: list[PlanStep] | None
    cost: float
    time_s: float
    stats: dict[str, Any]
    certificate: Certificate
    objects: dict[str, Any] = field(default_factory=dict)  # object name -> value
    # When not solved, why: goal facts unreachable even optimistically, streams never called
    # or never successful, the last skeletons tried.
    diagnostics: dict[str, Any] = field(default_factory=dict)

    @property
    def solved(self) -> bool:
        return self.status == SOLVED

    def to_json_dict(self) -> dict[str, Any]:
        plan = None if self.plan is None else [
            {"name": step.name, "args": [to_jsonable(v) for v in step.values],
             "objects": list(step.args), "cost": step.cost}
            for step in self.plan
        ]
        return {
            "status": self.status,
            "plan": plan,
            "cost": None if self.plan is None else self.cost,
            "time_s": round(self.time_s, 6),
            "stats": self.stats,
            **({"diagnostics": self.diagnostics} if self.diagnostics else {}),
        }

    def to_json(self) -> str:
        return json.dumps(self.to_json_dict(), sort_keys=False)


def to_jsonable(value: Any) -> Any:
    """Best-effort JSON form of an argument value (arrays and tuples become lists)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, list | tuple):
        return [to_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, str | int | float | bool) or value is None:
        return value
    if hasattr(value, "to_json"):
        return value.to_json()
    return repr(value)
