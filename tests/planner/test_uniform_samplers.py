"""Plain samplers: tamp2d_uniform (placements drawn uniformly, knowing nothing of other
blocks) and kitchen_fluent (a :fluents motion stream) are solved with valid plans, and the
adaptive algorithm does not lose its way in searches while sampling could fix its plan."""

from __future__ import annotations

from pathlib import Path

import pytest

from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"
GOAL_REGION = (5.0, 10.0)
BLOCK_WIDTH = 2.0
# Searches adaptive may need on tamp2d_uniform_tight_4 (seeds 0-4 need 5-7). Before the
# cheap-retry and speculative-search rules, seed 2 needed 17 searches (13 s) and other
# seeds timed out, each failed search raising the complexity by one.
MAX_SEARCHES_TIGHT_4 = 12


def final_poses(plan: list) -> dict[str, float]:  # type: ignore[type-arg]
    """Each block's last placed pose (m)."""
    poses: dict[str, float] = {}
    for step in plan:
        if step.name == "place":
            poses[step.values[0]] = float(step.values[1])
    return poses


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("layout", ["tight", "blocked"])
def test_uniform_two_blocks_solved_with_valid_plans(layout: str, seed: int) -> None:
    problem = load_problem(EXAMPLES / f"tamp2d_uniform_{layout}_2.yaml")
    result = solve(problem, PlannerConfig(algorithm="adaptive", seed=seed, max_time=30))
    assert result.solved, result.diagnostics
    assert validate_plan(problem, result).valid
    poses = final_poses(result.plan or [])
    goal_blocks = ["a", "b"] if layout == "tight" else ["a"]
    for block in goal_blocks:
        low, high = GOAL_REGION
        assert low + BLOCK_WIDTH / 2 <= poses[block] <= high - BLOCK_WIDTH / 2
    if layout == "tight":
        assert abs(poses["a"] - poses["b"]) > BLOCK_WIDTH  # both fit, without touching
    else:  # b had to leave the goal region's middle for a
        assert "b" in poses
    assert result.plan is not None and result.plan[-1].name == "move"  # back to q0


@pytest.mark.parametrize("seed", range(5))
def test_adaptive_keeps_few_searches_with_uniform_placements(seed: int) -> None:
    problem = load_problem(EXAMPLES / "tamp2d_uniform_tight_4.yaml")
    result = solve(problem, PlannerConfig(algorithm="adaptive", seed=seed, max_time=30))
    assert result.solved and validate_plan(problem, result).valid
    assert result.stats["searches"] <= MAX_SEARCHES_TIGHT_4, result.stats


@pytest.mark.parametrize("algorithm", ["binding", "focused", "incremental"])
def test_other_algorithms_solve_uniform_tight(algorithm: str) -> None:
    problem = load_problem(EXAMPLES / "tamp2d_uniform_tight_2.yaml")
    result = solve(problem, PlannerConfig(algorithm=algorithm, seed=0, max_time=30))
    assert result.solved and validate_plan(problem, result).valid


def test_kitchen_fluent_plans_motions_in_their_state() -> None:
    problem = load_problem(EXAMPLES / "kitchen_fluent.yaml")
    result = solve(problem, PlannerConfig(algorithm="adaptive", seed=0, max_time=60))
    assert result.solved, result.diagnostics
    assert validate_plan(problem, result).valid
    names = [step.name for step in result.plan or []]
    assert {"fill", "pour", "scoop", "dump", "stir"} <= set(names)
    # Every move's trajectory was planned for the object it carries in that state.
    held = None
    for step in result.plan or []:
        if step.name == "pick":
            held = step.values[0]
        elif step.name == "place":
            held = None
        elif step.name == "move":
            trajectory = str(step.values[1])
            assert trajectory.endswith(f" carrying {held}") if held else (
                "carrying" not in trajectory), (trajectory, held)
