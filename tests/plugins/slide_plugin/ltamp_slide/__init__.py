"""The ``slide`` backend: push a puck so that it stops at a target distance.

Skill ``push``: context ``target`` (m, in [1, 5]), control ``speed`` (m/s, in [0, 4]). The
puck decelerates at ``friction`` m/s² (1 ± 5 %, drawn from the trial's seed) and stops after
``speed² / (2 friction)`` m; the score is ``0.5 - |stop - target|`` (success: within 0.5 m).
``make_executor`` replays plans of the domain in ``domain/`` (actions ``push ?t ?v``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.execution import ExecutionReport
from ltamp_cli.backends.protocol import ParamSpace, SkillSpec, TrialResult

DOMAIN_DIR = Path(__file__).resolve().parent / "domain"


class SlideBackend:
    """One skill, ``push``; each trial is an analytic slide with a seeded friction."""

    name = "slide"

    def __init__(self) -> None:
        self._spec = SkillSpec(
            name="push",
            context=ParamSpace(("target",), (1.0,), (5.0,)),
            control=ParamSpace(("speed",), (0.0,), (4.0,)),
            description="push a puck to stop at a target distance (m)")

    def skills(self) -> dict[str, SkillSpec]:
        return {"push": self._spec}

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        return self._spec.context.sample_uniform(rng, 1)[0]

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return np.ones(len(np.atleast_2d(controls)), dtype=bool)

    def stop_distance(self, speed: float, seed: int) -> float:
        """Where the puck stops (m) for ``speed`` (m/s) in the trial of ``seed``."""
        friction = 1.0 + 0.05 * np.random.default_rng(seed).standard_normal()
        return float(speed) ** 2 / (2.0 * friction)

    def run_trial(self, skill: str, context: np.ndarray, control: np.ndarray,
                  seed: int) -> TrialResult:
        stop = self.stop_distance(float(control[0]), seed)
        return TrialResult(score=0.5 - abs(stop - float(context[0])), valid=True,
                           info={"stop": stop})

    def close(self) -> None:
        pass


class SlideExecutor:
    """Replays ``push ?t ?v`` actions: the goal holds if every pushed target is reached."""

    def execute(self, problem: Any, plan_result: Any, seed: int,
                render_path: str | Path | None = None) -> ExecutionReport:
        backend = SlideBackend()
        steps = []
        for index, step in enumerate(plan_result.plan):
            if step.name != "push":
                continue
            target, speed = float(step.values[0]), float(step.values[1])
            result = backend.run_trial("push", np.array([target]), np.array([speed]),
                                       seed * 1000 + index)
            steps.append({"target": target, "speed": speed, "stop": result.info["stop"],
                          "reached": result.score > 0})
        reached = all(step["reached"] for step in steps)
        return ExecutionReport(success=True, goal_holds=bool(steps) and reached,
                               details={"steps": steps})


def make_backend(**options: Any) -> SlideBackend:
    return SlideBackend()


def make_executor(**options: Any) -> SlideExecutor:
    return SlideExecutor()
