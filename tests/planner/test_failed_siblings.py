"""Speculative searches leave out the never-called siblings of generators that failed
(issue #19, ``optimistic.failed_siblings``, ``skeletons.HOLD_BACK_FAILED_SIBLINGS``).

kitchen_fluent: the coaster has one slot, where the saucer stands. Once
``sample-pose(mug, coaster)`` ran out with its one pose rejected, a speculative search
parked the pitcher on a fresh ``sample-pose(pitcher, coaster)`` pose (never called, so the
lowest level) on most seeds, and that stream plan died at once on the same slot.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from ltamp_cli.planner.algorithms import optimistic, skeletons
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.pddl.syntax import Stream
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"


def _instance(exhausted: bool, results: list[tuple[str, ...]], is_test: bool = False) -> Any:
    external = Stream.__new__(Stream)  # only its type is read
    return SimpleNamespace(exhausted=exhausted, results=results, is_test=is_test,
                           external=external, name="sample-pose")


def test_only_instances_that_ran_out_with_every_output_rejected_have_failed() -> None:
    failed = ("sample-pose", ("mug", "coaster"))
    used = ("sample-pose", ("spoon", "shelf"))  # ran out, one output accepted
    going = ("sample-pose", ("kettle", "tray"))  # rejected once, not run out
    objects = {"mug", "pitcher", "coaster", "table", "spoon", "shelf", "kettle", "tray"}
    state = SimpleNamespace(
        problem=SimpleNamespace(objects=objects),
        instances={failed: _instance(True, [("slot0",)]),
                   used: _instance(True, [("s1",), ("s2",)]),
                   going: _instance(False, [("t1",)])},
        rejected_outputs={failed: {("slot0",)}, used: {("s1",)}, going: {("t1",)}})
    siblings = optimistic.failed_siblings(state)  # type: ignore[arg-type]
    assert siblings
    assert siblings.holds(("sample-pose", ("pitcher", "coaster")))
    assert siblings.holds(("sample-pose", ("mug", "table")))
    assert not siblings.holds(("sample-pose", ("pitcher", "table")))
    assert not siblings.holds(("inverse-kinematics", ("pitcher", "coaster")))
    assert not siblings.holds(("sample-pose", ("pitcher", "shelf")))
    assert not siblings.holds(("sample-pose", ("pitcher", "tray")))
    # A sibling over a value the problem does not name (a sample) is not held back.
    assert not siblings.holds(("sample-pose", ("#sampled-object", "coaster")))
    assert not siblings.holds(("sample-pose", ("mug", "sampled-region")))
    assert not optimistic.failed_siblings(SimpleNamespace(  # type: ignore[arg-type]
        instances={}, rejected_outputs={}, problem=SimpleNamespace(objects=objects)))


def test_a_rejection_counts_against_a_generator_only_when_it_sampled_alone() -> None:
    pose, other = _instance(False, [("p1",)]), _instance(False, [("p2",)])
    pose.inputs, other.inputs = ("mug", "table"), ("pitcher", "table")
    # Two sampled values: the combination failed, neither generator is blamed.
    problem = SimpleNamespace(objects={"mug": None, "pitcher": None, "saucer": None,
                                       "saucer-start": None})
    state = SimpleNamespace(rejected_outputs={}, problem=problem)
    optimistic.record_rejection(state, ("mug", "p1", "pitcher", "p2"),  # type: ignore[arg-type]
                                {"p1": (pose, ("p1",)), "p2": (other, ("p2",))})
    assert state.rejected_outputs == {}
    # One sampled value against the problem's own: evidence against its generator.
    optimistic.record_rejection(state, ("mug", "p1", "saucer", "saucer-start"),  # type: ignore[arg-type]
                                {"p1": (pose, ("p1",))})
    assert state.rejected_outputs == {("sample-pose", ("mug", "table")): {("p1",)}}
    # Against a value sampled by an earlier stream plan (not the problem's): not blamed.
    state = SimpleNamespace(rejected_outputs={}, problem=problem)
    optimistic.record_rejection(state, ("mug", "p1", "saucer", "p0"),  # type: ignore[arg-type]
                                {"p1": (pose, ("p1",))})
    assert state.rejected_outputs == {}


def fixed_cost_clock(seconds_per_call: float) -> Callable[[], float]:
    """Every stream call measures ``seconds_per_call`` of CPU, whatever the machine's load
    (the cheap/expensive decisions are then deterministic)."""
    ticks = itertools.count()
    return lambda: next(ticks) * seconds_per_call


def run(seed: int) -> Any:
    problem = load_problem(EXAMPLES / "kitchen_fluent.yaml")
    result = solve(problem, PlannerConfig(algorithm="adaptive", seed=seed, max_time=60,
                                          stream_cpu_clock=fixed_cost_clock(20e-6)))
    assert result.solved
    report = validate_plan(problem, result)
    assert report.valid, report.errors
    return result


@pytest.mark.slow
def test_speculative_searches_leave_the_coasters_fresh_siblings_out(
        monkeypatch: pytest.MonkeyPatch) -> None:
    seeds = [2, 9]
    with monkeypatch.context() as patch:
        patch.setattr(skeletons, "HOLD_BACK_FAILED_SIBLINGS", False)
        without = [run(seed) for seed in seeds]
    held: list[tuple[Any, Any]] = []
    evaluate = skeletons.optimistic_evaluation

    def recorded(state: Any, complexity: int, placeholders: Any, held_back: Any = None) -> Any:
        evaluation = evaluate(state, complexity, placeholders, held_back)
        if held_back:
            # No never-called sibling of a failed generator certified anything.
            for key in evaluation.outputs:
                instance = state.instances.get(key)
                assert not held_back.holds(key) or (instance is not None
                                                    and instance.num_calls), key
            held.append((held_back, evaluation))
        return evaluation

    monkeypatch.setattr(skeletons, "optimistic_evaluation", recorded)
    with_hold_back = [run(seed) for seed in seeds]
    assert held, "no speculative search held an instance back"
    assert all(evaluation.cut for _, evaluation in held)
    assert any(s.holds(("sample-pose", ("pitcher", "coaster"))) for s, _ in held)
    before = sum(r.stats["searches"] for r in without)
    after = sum(r.stats["searches"] for r in with_hold_back)
    assert after < before, (before, after)


@pytest.mark.slow
def test_a_failed_motion_probes_its_siblings_in_the_same_state(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # kitchen_fluent seed 20: the pitcher carried past a tall object; without the probe
    # the motion to the mug's configuration failed from one start after another, a search
    # each.
    with monkeypatch.context() as patch:
        patch.setattr(skeletons, "CONTEXT_SIBLING_PROBE_CALLS", 0)
        without = run(20)
    probed: list[tuple[Any, list[Any]]] = []
    probe = skeletons.probe_context_siblings

    def recorded(state: Any, failed: Any) -> None:
        before = set(state.instances)
        probe(state, failed)
        new = [state.instances[k] for k in state.instances if k not in before]
        probed.append((failed, new))

    monkeypatch.setattr(skeletons, "probe_context_siblings", recorded)
    result = run(20)
    assert probed and any(new for _, new in probed)
    for failed, new in probed:
        assert len(new) <= skeletons.CONTEXT_SIBLING_PROBE_CALLS
        for sibling in new:
            # same stream and state, one input changed, called once
            assert sibling.name == failed.name and sibling.fluent_facts == failed.fluent_facts
            assert sum(a != b for a, b in zip(sibling.inputs, failed.inputs, strict=True)) == 1
            assert sibling.num_calls == 1
    assert result.stats["searches"] < without.stats["searches"], (
        without.stats["searches"], result.stats["searches"])
