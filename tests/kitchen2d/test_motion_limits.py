"""Executed Kitchen2D motions are acceleration-limited and carried contents stay put."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.backends.box2d.executor import (
    ACCELERATION,
    ANGULAR_ACCELERATION,
    Kitchen2DExecutor,
    Kitchen2DRun,
)
from ltamp_cli.backends.box2d.scene import scene_from_world
from ltamp_cli.motion.timing import peak_rates
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem

ROOT = Path(__file__).resolve().parents[2]
PROBLEMS = sorted((ROOT / "problems" / "kitchen2d").glob("*.yaml"))
DT = 0.01


def _execute(path: Path, seed: int) -> Kitchen2DRun:
    """Plan ``path`` and execute the plan step by step, keeping the run for inspection."""
    problem = load_problem(path)
    result = solve(problem, PlannerConfig(max_time=60, seed=seed))
    assert result.solved, path.name
    run = Kitchen2DRun(scene_from_world(problem.world, np.random.default_rng(seed)), seed,
                       None)
    executor = Kitchen2DExecutor()
    for step in result.plan:
        executor._dispatch(run, step)
        assert not run.hit, (path.name, step.name, run.hit)
    return run


def _check(run: Kitchen2DRun) -> None:
    assert run.commanded, "no motion went through the timed path follower"
    for trajectory in run.commanded:
        # Each starts and ends at rest (peak_rates assumes so at both ends).
        _, accels = peak_rates(trajectory, DT, ((0, 1), (2,)))
        assert accels[0] <= ACCELERATION + 1e-6 and accels[1] <= ANGULAR_ACCELERATION + 1e-6
    carries = [entry for entry in run.log if "carry" in entry]
    for carry in carries:
        # Liquid and grains carried in a cup stay in it (all of them, not just at the goal).
        assert carry["after"] == carry["before"], carry


def test_fill_and_serve_motions_are_bounded_and_the_carried_water_stays() -> None:
    run = _execute(ROOT / "problems" / "kitchen2d" / "fill_and_serve.yaml", 3)
    _check(run)
    carries = [entry for entry in run.log if "carry" in entry]
    assert any(entry["before"] > 50 for entry in carries), run.log  # a full cup was carried


@pytest.mark.slow
@pytest.mark.parametrize("path", PROBLEMS, ids=[p.stem for p in PROBLEMS])
def test_every_shipped_problem_carries_without_spilling(path: Path) -> None:
    _check(_execute(path, 1))
