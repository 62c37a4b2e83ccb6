"""Adaptive's cheap retries (``skeletons.CHEAP_RETRY_FACTOR``) are for failures that more
samples fix: a test or stream that rejected two values sampled by streams. The red-team
rover (``tests/robustness/redteam_problems.py``) has a route stream (``:fluents``) that
fails from every sampled rock configuration home while the debris lies on the ground; with
the bonus for every failure, adaptive drew 31 rock configurations (each a new, equally
doomed skeleton and a search), 52 searches and ~4 s CPU where binding needs 8 searches."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "robustness"))

import redteam_problems as problems

from ltamp_cli.pddlstream.solve import to_planning_problem, to_solution
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve


@pytest.mark.parametrize("seed", [0, 1])
def test_rover_adaptive_samples_what_binding_samples(tmp_path: Path, seed: int) -> None:
    problem, check = problems.rover_problem(tmp_path, seed=seed)
    planning_problem = to_planning_problem(problem, None)
    adaptive = solve(planning_problem, PlannerConfig(algorithm="adaptive", seed=seed,
                                                     max_time=60))
    binding = solve(planning_problem, PlannerConfig(algorithm="binding", seed=seed,
                                                    max_time=60))
    assert adaptive.solved and binding.solved
    samples = adaptive.stats["streams"]["sample-near"]["calls"]
    assert samples <= 2 * binding.stats["streams"]["sample-near"]["calls"], samples
    assert adaptive.stats["searches"] <= 2 * binding.stats["searches"], adaptive.stats
    # replayed on the values: the debris is cleared before the rover drives through it
    check(to_solution(adaptive).plan)
