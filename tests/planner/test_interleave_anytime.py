"""The interleaved incremental member over a whole solve (issue #19, ``algorithms/interleave.py``):

* anytime rounds go on with the solve's one member (main made a new one each round: another
  ``make_streams``, a new grace, the previous member's samples dropped);
* the member's stream calls are persisted to the stream statistics and shown in ``--json``
  (main persisted and showed the optimistic member's only), without double counting;
* the member's ``make_streams`` is setup, not CPU of its first slice.

``GRACE_UNITS`` is set to 0 here so that the member runs from the first iteration of small
problems (its share is unchanged); the grace itself is tested in ``test_interleave.py``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from ltamp_cli.planner.algorithms import interleave
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import PlanningProblem, load_problem
from ltamp_cli.planner.statistics import statistics_file_name
from ltamp_cli.planner.validate import validate_plan

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"


@pytest.fixture
def no_grace(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(interleave, "GRACE_UNITS", 0.0)


def counting(problem: PlanningProblem, made: list[int],
             on_call: Callable[[], None] = lambda: None) -> PlanningProblem:
    """``problem`` whose ``make_streams`` appends to ``made`` (and runs ``on_call``)."""
    factory = problem.streams_factory
    assert factory is not None

    def make_streams(world: Any, rng: Any) -> Any:
        made.append(1)
        on_call()
        return factory(world, rng)

    return replace(problem, streams_factory=make_streams)


@pytest.mark.usefixtures("no_grace")
@pytest.mark.parametrize("algorithm", ["adaptive", "binding", "focused"])
def test_anytime_rounds_go_on_with_one_member(algorithm: str) -> None:
    """tamp2d_uniform_tight_2 seed 0, anytime until a plan costs at most 114.6: plans of
    121.1, then 115.6 or 115.0, ..., 114.6 (adaptive, binding; focused: 121.7, ..., 114.5),
    three rounds or more. One ``make_streams`` for the optimistic member and one for the
    member, whatever the number of rounds (main, adaptive and binding: one more for each
    round in which the member ran, 3 in all), and the member serves every round."""
    made: list[int] = []
    problem = counting(load_problem(EXAMPLES / "tamp2d_uniform_tight_2.yaml"), made)
    result = solve(problem, PlannerConfig(algorithm=algorithm, seed=0, max_time=60,
                                          success_cost=114.6))
    assert result.solved and result.cost <= 114.6
    costs = result.stats["anytime_costs"]
    assert len(costs) >= 2 and costs[0] > 120.0
    assert len(made) == 2
    member = result.stats["interleaved"]
    assert member["rounds"] == len(costs)
    assert validate_plan(problem, result).valid


def stream_calls(streams: dict[str, dict[str, float]]) -> int:
    return int(sum(s["calls"] for s in streams.values()))


@pytest.mark.usefixtures("no_grace")
@pytest.mark.parametrize("name", ["tamp2d_blocked", "tamp2d_4blocks"])
def test_the_members_stream_calls_are_persisted_and_reported_once(
        tmp_path: Path, name: str) -> None:
    """tamp2d_blocked: the member's plan; tamp2d_4blocks: the optimistic member's, after
    the member ran. Either way ``stats["streams"]`` and the persisted statistics hold both
    members' calls, each once (main: the optimistic member's only), and the seconds of
    searches and stream calls still add up to at most the solve's."""
    problem = load_problem(EXAMPLES / f"{name}.yaml")
    result = solve(problem, PlannerConfig(algorithm="adaptive", seed=0, max_time=60,
                                          statistics_dir=str(tmp_path)))
    assert result.solved
    member = result.stats["interleaved"]
    assert member["stream_calls"] > 0
    shown = stream_calls(result.stats["streams"])
    file = tmp_path / statistics_file_name(problem.domain.name)
    persisted = json.loads(file.read_text())["streams"]
    assert stream_calls(persisted) == shown
    # Both members' calls: the member's are part of the total, not all of it.
    assert shown > member["stream_calls"]
    assert result.stats["searches"] > member["searches"]
    stats = result.stats
    assert stats["search_time_s"] + stats["sampling_time_s"] <= result.time_s + 1e-6
    # A second solve adds its own calls to the history, nothing more.
    again = solve(problem, PlannerConfig(algorithm="adaptive", seed=0, max_time=60,
                                         statistics_dir=str(tmp_path)))
    persisted = json.loads(file.read_text())["streams"]
    assert stream_calls(persisted) == shown + stream_calls(again.stats["streams"])


@pytest.mark.usefixtures("no_grace")
def test_the_members_make_streams_is_setup_not_a_slice() -> None:
    """A ``make_streams`` that costs a second of (injected) CPU: the member's second call
    of it is reported as ``setup_cpu_s``, not as CPU of its steps (main: 1 s in
    ``cpu_s``); its work units, which decide the turns, never counted it."""
    offset = [0.0]
    made: list[int] = []

    def costly_setup() -> None:
        offset[0] += 1.0

    problem = counting(load_problem(EXAMPLES / "tamp2d_blocked.yaml"), made, costly_setup)
    clock = lambda: time.thread_time() + offset[0]  # noqa: E731
    result = solve(problem, PlannerConfig(algorithm="adaptive", seed=0, max_time=60,
                                          stream_cpu_clock=clock))
    plain = solve(problem, PlannerConfig(algorithm="adaptive", seed=0, max_time=60))
    assert result.solved and len(made) == 4
    member = result.stats["interleaved"]
    assert member["setup_cpu_s"] == pytest.approx(1.0, abs=0.2)
    assert member["cpu_s"] < 0.9
    assert member["work_units"] == plain.stats["interleaved"]["work_units"]
