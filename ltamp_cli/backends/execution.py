"""Executing a plan in a backend's simulator and checking the goal physically.

A backend that can replay plans provides ``make_executor(**options) -> PlanExecutor`` in the
module of its factory (built-in: ``ltamp_cli.backends.<name>``; plugins: the module of their
``ltamp.backends`` entry point), next to ``make_backend``. :func:`execute_plan` loads it
lazily, the way :func:`ltamp_cli.backends.load_backend` loads backends.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from ltamp_cli.backends.frames import GifTiming
from ltamp_cli.errors import InputError
from ltamp_cli.extras import missing_module_hint


@dataclass(frozen=True)
class ExecutionReport:
    """Outcome of replaying a plan.

    ``success``: every action ran as planned (grasps closed on the intended object, motions
    completed); ``goal_holds``: the goal facts hold *in the simulated world* at the end,
    checked physically (not by trusting the plan). ``details`` is JSON-able (per-step and
    per-goal-fact results, particle counts, simulated seconds, ...).
    """

    success: bool
    goal_holds: bool
    details: dict[str, Any] = field(default_factory=dict)


@runtime_checkable
class PlanExecutor(Protocol):
    """Replays a :class:`~ltamp_cli.planner.result.PlanResult` of a planning problem.

    ``execute`` must be deterministic given ``seed`` (the planner's seed, from which the
    problem's randomised arrangement is rebuilt) and writes an animation to
    ``render_path`` (``.gif``; another suffix: the last frame as an image) when given.
    """

    def execute(
        self, problem: Any, plan_result: Any, seed: int, render_path: str | Path | None = None
    ) -> ExecutionReport: ...


def load_executor(backend_name: str, **options: Any) -> PlanExecutor:
    """``make_executor(**options)`` of the module of backend ``backend_name`` (a built-in
    backend or an ``ltamp.backends`` plugin); ``InputError`` if the backend is unknown or
    cannot execute plans."""
    from ltamp_cli.backends import backend_module

    try:
        module, _ = backend_module(backend_name)
    except InputError as error:
        raise InputError(f"--backend: {error.message}") from None
    factory = getattr(module, "make_executor", None)
    if factory is None:
        raise InputError(f"--backend: backend {backend_name!r} cannot execute plans")
    try:
        return factory(**options)
    except ImportError as error:
        raise InputError(f"--backend: backend {backend_name!r} is not available here: {error}"
                         f"{missing_module_hint(error)}") from None


def execute_plan(
    backend_name: str,
    problem: Any,
    plan_result: Any,
    seed: int,
    render_path: str | Path | None = None,
    timing: GifTiming | None = None,
) -> ExecutionReport:
    """Replay ``plan_result`` (a solved plan of ``problem``) on ``backend_name``; the GIF
    at ``render_path`` follows ``timing`` (default: the executor's, see
    :class:`~ltamp_cli.backends.frames.GifTiming`)."""
    if plan_result.plan is None:
        raise ValueError("execute_plan needs a solved plan")
    executor = load_executor(backend_name, **({} if timing is None else {"timing": timing}))
    return executor.execute(problem, plan_result, seed, render_path)


__all__ = ["ExecutionReport", "PlanExecutor", "execute_plan", "load_executor"]
