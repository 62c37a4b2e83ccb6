"""RRT-Connect in a bounded joint space through OMPL 2.0.1's nanobind bindings.

OMPL is a hard dependency (no fallback planner). Notes on these bindings:

* there is no ``ScopedState``: states come from ``space.allocState()`` and are indexed ``s[i]``;
* calling ``ss.getProblemDefinition().getStartState(0)`` makes the next ``solve()`` segfault,
  so this module never reads states back from the problem definition;
* OMPL's RNG is process-global. ``ompl.util.RNG.setSeed`` re-seeds the generator of seeds, so
  setting it right before building a fresh planner makes a run deterministic *as long as it is
  not cut short by the time limit* (a timed-out run depends on the machine's speed). OMPL logs
  an error when re-seeding after the first RNG exists; the log level is lowered for the call
  and restored afterwards.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from ltamp_cli.motion.interpolation import is_path_valid, shortcut_path

ValidityFn = Callable[[np.ndarray], bool]


@dataclass(frozen=True)
class RRTConnectConfig:
    """Settings of one RRT-Connect query.

    ``resolution``: largest joint change (radians, infinity norm) between checked
    configurations on an edge, for OMPL's motion checks and the final dense re-check.
    ``max_step``: RRT-Connect's extension range in joint units (``None``: OMPL's default,
    a fifth of the space's extent). ``shortcut_iterations``: random shortcutting attempts
    (:func:`~ltamp_cli.motion.interpolation.shortcut_path`, seeded from ``seed``; OMPL's
    own simplifier is time-bounded and so not reproducible); 0 disables it.
    ``max_checks``: budget of validity checks for the search (``None``: none). A search
    stopped by it depends only on the seed, not on the machine's speed or load;
    ``time_limit`` then only caps the calling thread's CPU time (not wall time: on a loaded
    machine a wall cap stopped carrying motions of 3D coffee before their check budget,
    so that which motions were found depended on the load). Without ``max_checks``,
    ``time_limit`` is OMPL's own (wall) limit.
    """

    time_limit: float = 2.0
    seed: int = 0
    resolution: float = 0.02
    max_step: float | None = None
    shortcut_iterations: int = 20
    max_checks: int | None = None

    def __post_init__(self) -> None:
        if self.time_limit <= 0:
            raise ValueError("time_limit must be positive")
        if self.resolution <= 0:
            raise ValueError("resolution must be positive")
        if self.max_step is not None and self.max_step <= 0:
            raise ValueError("max_step must be positive")
        if self.shortcut_iterations < 0:
            raise ValueError("shortcut_iterations must be >= 0")
        if self.max_checks is not None and self.max_checks <= 0:
            raise ValueError("max_checks must be positive")


@dataclass(frozen=True)
class MotionPlan:
    """Result of a query. ``path`` has shape ``(n_waypoints, dof)`` or is ``None``.

    ``status`` is ``"solved"`` or says why not (``"start invalid"``, ``"goal invalid"``,
    ``"start out of bounds"``, ``"goal out of bounds"``, ``"timeout"``,
    ``"dense re-check failed"``). ``planning_time`` is wall-clock seconds.
    """

    path: np.ndarray | None
    status: str
    planning_time: float
    n_validity_checks: int

    @property
    def success(self) -> bool:
        return self.path is not None


def plan_rrt_connect(
    start: np.ndarray,
    goal: np.ndarray,
    lows: np.ndarray,
    highs: np.ndarray,
    is_valid: ValidityFn,
    config: RRTConnectConfig | None = None,
) -> MotionPlan:
    """Plan a valid joint path from ``start`` to ``goal`` (both shape ``(dof,)``).

    ``lows``/``highs`` (shape ``(dof,)``) bound the space; ``is_valid(q)`` says whether a
    configuration is allowed (collision-free and any extra constraint). The returned path
    starts at ``start``, ends at ``goal`` and has been re-checked with ``is_valid`` at
    ``config.resolution``. An exception raised by ``is_valid`` propagates to the caller.
    """
    settings = config or RRTConnectConfig()
    q_start = np.asarray(start, dtype=float)
    q_goal = np.asarray(goal, dtype=float)
    low = np.asarray(lows, dtype=float)
    high = np.asarray(highs, dtype=float)
    dof = low.shape[0]
    for name, array in (("start", q_start), ("goal", q_goal), ("highs", high)):
        if array.shape != (dof,):
            raise ValueError(f"{name} must have shape ({dof},), got {array.shape}")
    if np.any(low >= high):
        raise ValueError("every low must be < its high")

    began = time.perf_counter()
    counter = _CountingValidity(is_valid)
    for name, q in (("start", q_start), ("goal", q_goal)):
        if np.any(q < low) or np.any(q > high):
            return MotionPlan(None, f"{name} out of bounds", 0.0, counter.calls)
        if not counter(q):
            counter.raise_pending()
            return MotionPlan(None, f"{name} invalid", time.perf_counter() - began, counter.calls)

    raw_path = _solve_with_ompl(q_start, q_goal, low, high, counter, settings)
    counter.raise_pending()
    if raw_path is None:
        return MotionPlan(None, "timeout", time.perf_counter() - began, counter.calls)
    if settings.shortcut_iterations > 0:
        raw_path = shortcut_path(
            raw_path,
            counter,
            settings.resolution,
            np.random.default_rng(settings.seed),
            settings.shortcut_iterations,
        )
        counter.raise_pending()
    # Re-check densely ourselves: never trust a path only because the planner returned it.
    if not is_path_valid(raw_path, counter, settings.resolution):
        counter.raise_pending()
        return MotionPlan(None, "dense re-check failed", time.perf_counter() - began, counter.calls)
    return MotionPlan(raw_path, "solved", time.perf_counter() - began, counter.calls)


class _CountingValidity:
    """Wraps the user's callback: counts calls and keeps exceptions away from C++."""

    def __init__(self, is_valid: ValidityFn) -> None:
        self._is_valid = is_valid
        self.calls = 0
        self._error: BaseException | None = None

    def __call__(self, q: np.ndarray) -> bool:
        if self._error is not None:
            return False
        self.calls += 1
        try:
            return bool(self._is_valid(q))
        except Exception as error:  # re-raised after OMPL returns
            self._error = error
            return False

    def raise_pending(self) -> None:
        if self._error is not None:
            error, self._error = self._error, None
            raise error


def _solve_with_ompl(
    q_start: np.ndarray,
    q_goal: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    is_valid: _CountingValidity,
    settings: RRTConnectConfig,
) -> np.ndarray | None:
    dof = low.shape[0]
    previous_level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)
    try:
        ou.RNG.setSeed(int(settings.seed) % 2_147_483_646 + 1)
        space = ob.RealVectorStateSpace(dof)
        bounds = ob.RealVectorBounds(dof)
        for i in range(dof):
            bounds.setLow(i, float(low[i]))
            bounds.setHigh(i, float(high[i]))
        space.setBounds(bounds)
        setup = og.SimpleSetup(space)

        def check_state(state: ob.State) -> bool:
            return is_valid(np.fromiter((state[i] for i in range(dof)), float, count=dof))

        setup.setStateValidityChecker(check_state)
        information = setup.getSpaceInformation()
        information.setStateValidityCheckingResolution(
            min(1.0, settings.resolution / space.getMaximumExtent())
        )
        planner = og.RRTConnect(information)
        if settings.max_step is not None:
            planner.setRange(settings.max_step)
        setup.setPlanner(planner)
        start_state = space.allocState()
        goal_state = space.allocState()
        for i in range(dof):
            start_state[i] = float(q_start[i])
            goal_state[i] = float(q_goal[i])
        setup.setStartAndGoalStates(start_state, goal_state)
        if settings.max_checks is None:
            setup.solve(settings.time_limit)
        else:
            deadline = time.thread_time() + settings.time_limit
            budget = is_valid.calls + settings.max_checks

            def exhausted() -> bool:
                return is_valid.calls >= budget or time.thread_time() > deadline

            setup.solve(ob.PlannerTerminationCondition(exhausted))
        if not setup.haveExactSolutionPath():
            return None
        solution = setup.getSolutionPath()
        path = np.array(
            [
                [solution.getState(k)[i] for i in range(dof)]
                for k in range(solution.getStateCount())
            ],
            dtype=float,
        )
    finally:
        ou.setLogLevel(previous_level)
    # The endpoints are the exact query configurations (OMPL copies them, but be exact).
    path[0] = q_start
    path[-1] = q_goal
    return path
