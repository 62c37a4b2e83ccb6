"""The symbolic kitchen's slot sampler offers taken slots last, and with it (and the cold-start
probe after the eager streams) the optimistic algorithms plan the coffee task in one search
on seeds that used to need 7-13."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ltamp_cli.errors import SourceLocation
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem, load_streams_factory

ROOT = Path(__file__).resolve().parents[2]


def make_streams(world: dict[str, Any], seed: int) -> dict[str, Any]:
    """The domain's bindings, loaded as a problem file naming them would load them."""
    folder = ROOT / "domains" / "kitchen_symbolic"
    factory = load_streams_factory("streams.py", folder, SourceLocation(str(folder)))
    return dict(factory(world, np.random.default_rng(seed)))


@pytest.mark.parametrize("seed", range(5))
def test_slots_where_objects_were_seen_come_last(seed: int) -> None:
    streams = make_streams({"slots": {"table": 5}}, seed)
    # The problem put two objects on table/0 and table/3 (seen as a collision test's inputs).
    streams["test-cfree"].function("cup", "table/0", "bowl", "table/3")
    offered = [pose for (pose,) in streams["sample-pose"]("cup", "table")]
    assert sorted(offered) == [f"table/{i}" for i in range(5)]  # every slot, once
    assert set(offered[:3]) == {"table/1", "table/2", "table/4"}


def fixed_cost_clock(seconds_per_call: float) -> Callable[[], float]:
    """A CPU clock for stream calls under which every call measures ``seconds_per_call``
    (each call reads the clock twice), whatever the machine's load: the planner's
    cheap/expensive decision (``effort.AUTO_EAGER_MAX_OVERHEAD_S``, 1 ms) then does not
    depend on measured time (a garbage collection inside a 20 us call once made it
    expensive under load: 5 searches instead of 1)."""
    ticks = itertools.count()
    return lambda: next(ticks) * seconds_per_call


def solve_coffee(algorithm: str, seed: int, seconds_per_call: float) -> Any:
    problem = load_problem(ROOT / "problems" / "examples" / "kitchen_symbolic.yaml")
    options = {k: v for k, v in problem.planner_options.items() if k != "max_time"}
    return solve(problem, PlannerConfig(algorithm=algorithm, seed=seed, max_time=60,
                                        stream_cpu_clock=fixed_cost_clock(seconds_per_call),
                                        **options))


@pytest.mark.parametrize("algorithm", ["adaptive", "focused", "binding"])
@pytest.mark.parametrize("seed", [6, 11])
def test_coffee_is_planned_in_one_search(algorithm: str, seed: int) -> None:
    # The domain's samplers are closed-form Python (~10-50 us a call): cheap.
    result = solve_coffee(algorithm, seed, 20e-6)
    assert result.solved
    assert result.stats["searches"] == 1


@pytest.mark.parametrize("seed", [6, 11])
def test_the_injected_clock_decides_what_is_cheap(seed: int) -> None:
    """The premise above: measured as expensive (1 ms a call), the streams are not made
    eager, and the same seeds need more than one search."""
    result = solve_coffee("binding", seed, 1e-3)
    assert result.solved
    assert result.stats["searches"] > 1
