"""Several conflicts learned from one failed stream plan (``skeletons.probe_siblings``).

kitchen_fluent's coaster has one slot, where the saucer stands. An optimistic plan may park
several objects on "fresh" coaster poses; binding it fails at the first such placement (the
sampler's only slot collides with the saucer, then the sampler runs out). Without the probe
each other object's coaster sampler cost one more search and skeleton; with it, the other
coaster samplers of the failed stream plan are tried with the plan's collision tests at
once and run out before the next search.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from ltamp_cli.planner.algorithms import skeletons
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"


def fixed_cost_clock(seconds_per_call: float) -> Callable[[], float]:
    """Every stream call measures ``seconds_per_call`` of CPU (the clock is read twice a
    call): the cheap/expensive decision, which the probe depends on, is then the same
    whatever the machine's load."""
    ticks = itertools.count()
    return lambda: next(ticks) * seconds_per_call


def run(algorithm: str, seed: int) -> Any:
    problem = load_problem(EXAMPLES / "kitchen_fluent.yaml")
    result = solve(problem, PlannerConfig(algorithm=algorithm, seed=seed, max_time=60,
                                          stream_cpu_clock=fixed_cost_clock(20e-6)))
    assert result.solved
    report = validate_plan(problem, result)
    assert report.valid, report.errors
    return result


@pytest.mark.parametrize("algorithm", ["adaptive", "binding"])
def test_exhausted_siblings_are_learned_before_the_next_search(
        algorithm: str, monkeypatch: pytest.MonkeyPatch) -> None:
    seeds = [1, 6]  # seeds whose plans park several objects on the coaster on the way
    # The refinement probe learns the mug's coaster pose before these plans are searched
    # (adaptive then finds the saucer's detour at once): the sibling probe is measured
    # without it.
    monkeypatch.setattr(skeletons, "REFINEMENT_PROBE_OUTPUTS", 0)
    # Also without the later mechanisms that learn the coaster's siblings otherwise:
    # adaptive's speculative searches leave failed generators' siblings out, and seed 6
    # then searches 8 times with and without this probe.
    monkeypatch.setattr(skeletons, "HOLD_BACK_FAILED_SIBLINGS", False)
    monkeypatch.setattr(skeletons, "CONTEXT_SIBLING_PROBE_CALLS", 0)
    with monkeypatch.context() as patch:
        patch.setattr(skeletons, "SIBLING_PROBE_OUTPUTS", 0)
        without = [run(algorithm, seed) for seed in seeds]
    calls: list[tuple[str, tuple[str, ...]]] = []
    probe = skeletons.probe_siblings

    def recorded(state: Any, failed: Any) -> None:
        calls.append(failed.skeleton.stream_plan[failed.step])
        probe(state, failed)

    monkeypatch.setattr(skeletons, "probe_siblings", recorded)
    probed = [run(algorithm, seed) for seed in seeds]
    assert calls, "no generator of a stream plan ran out"
    for before, after in zip(without, probed, strict=True):
        # fewer searches on each seed, and the plan is no longer
        assert after.stats["searches"] < before.stats["searches"], (
            before.stats["searches"], after.stats["searches"])
        assert len(after.plan) <= len(before.plan)


def test_only_cheap_generators_are_probed(monkeypatch: pytest.MonkeyPatch) -> None:
    # Measured at 1 ms a call, kitchen_fluent's samplers are not cheap: no sibling is
    # called, and the solve is the one without the probe (generators do run out on the
    # way: treated as cheap, the probe changes this solve's searches from 11 to 9).
    problem = load_problem(EXAMPLES / "kitchen_fluent.yaml")

    def solve_at(outputs: int) -> Any:
        with monkeypatch.context() as patch:
            patch.setattr(skeletons, "SIBLING_PROBE_OUTPUTS", outputs)
            return solve(problem, PlannerConfig(algorithm="binding", seed=1, max_time=60,
                                                stream_cpu_clock=fixed_cost_clock(1e-3)))

    expensive, off = solve_at(4), solve_at(0)
    assert expensive.solved and off.solved
    assert expensive.stats["searches"] == off.stats["searches"]
    assert {name: stats["calls"] for name, stats in expensive.stats["streams"].items()} == {
        name: stats["calls"] for name, stats in off.stats["streams"].items()}
