"""Fewer searches per solve (issue #19): a refined plan's cheap generators are probed before
the search that follows the refinement (``skeletons.probe_refined_plan``), and a stream plan
never calls an entry before the entries that produce its ``:fluents`` context
(``optimistic._after_their_contexts``).

kitchen_fluent: the first plan over shared configurations serves the mug on a fresh coaster
pose; the coaster's one slot holds the saucer. Without the probe the refined plan's stream
plan died on that pose and a third plan (move the saucer first) was searched on every seed.
"""

from __future__ import annotations

import itertools
import random
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from ltamp_cli.planner.algorithms import optimistic, skeletons
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"


def fixed_cost_clock(seconds_per_call: float) -> Callable[[], float]:
    """Every stream call measures ``seconds_per_call`` of CPU, whatever the machine's load
    (the cheap/expensive decisions the probe depends on are then deterministic)."""
    ticks = itertools.count()
    return lambda: next(ticks) * seconds_per_call


def run(algorithm: str, seed: int, seconds_per_call: float = 20e-6) -> Any:
    problem = load_problem(EXAMPLES / "kitchen_fluent.yaml")
    result = solve(problem, PlannerConfig(algorithm=algorithm, seed=seed, max_time=60,
                                          stream_cpu_clock=fixed_cost_clock(seconds_per_call)))
    assert result.solved
    report = validate_plan(problem, result)
    assert report.valid, report.errors
    return result


@pytest.mark.parametrize("algorithm", ["adaptive", "binding"])
def test_refined_plans_generators_are_probed_before_the_next_search(
        algorithm: str, monkeypatch: pytest.MonkeyPatch) -> None:
    seeds = [0, 1]
    with monkeypatch.context() as patch:
        patch.setattr(skeletons, "REFINEMENT_PROBE_OUTPUTS", 0)
        without = [run(algorithm, seed) for seed in seeds]
    probes: list[int] = []
    probe = skeletons.probe_refined_plan

    def recorded(state: Any, evaluation: Any, needed: Any, refined: Any) -> None:
        before = len(state.instances)
        probe(state, evaluation, needed, refined)
        probes.append(len(state.instances) - before)

    monkeypatch.setattr(skeletons, "probe_refined_plan", recorded)
    probed = [run(algorithm, seed) for seed in seeds]
    assert probes and any(probes), "no refined plan was probed"
    for before, after in zip(without, probed, strict=True):
        # a search fewer on each seed, and the plan is no longer
        assert after.stats["searches"] < before.stats["searches"], (
            before.stats["searches"], after.stats["searches"])
        assert len(after.plan) <= len(before.plan)


def test_costly_generators_are_called_at_most_once_by_the_probe(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # At 1 ms a call no stream is cheap: an unmeasured generator gets the one call that
    # measures it, and no second output is asked for by the probe.
    calls: list[tuple[str, int]] = []
    probe = skeletons._probe

    def recorded(state: Any, instance: Any, outputs: Any, tests: Any, limit: int,
                 **options: Any) -> None:
        probe(state, instance, outputs, tests, limit, **options)
        calls.append((instance.name, instance.num_calls))

    monkeypatch.setattr(skeletons, "_probe", recorded)
    run("adaptive", 0, seconds_per_call=1e-3)
    assert all(num_calls <= 1 for _, num_calls in calls), calls


def _entry(name: str, inputs: tuple[str, ...], outputs: tuple[str, ...] = (),
           context: tuple[tuple[str, ...], ...] = ()) -> list:
    return [(name, inputs), outputs, context]


def test_an_entry_comes_after_the_producers_of_its_context() -> None:
    motion = _entry("plan-motion", ("@q1", "@q2"), ("#t1",),
                    (("AtPose", "pitcher", "#p3"), ("AtPose", "spoon", "#p7")))
    pitcher = _entry("sample-pose", ("pitcher", "table"), ("#p3",))
    spoon = _entry("sample-pose", ("spoon", "table"), ("#p7",))
    test = _entry("test-cfree", ("pitcher", "#p3", "spoon", "#p7"))
    uses_motion = _entry("test-traj", ("#t1",))
    ordered = optimistic._after_their_contexts([motion, uses_motion, pitcher, test, spoon])
    names = [(e[0][0], e[1]) for e in ordered]
    assert names.index(("plan-motion", ("#t1",))) > names.index(("sample-pose", ("#p7",)))
    assert names.index(("plan-motion", ("#t1",))) > names.index(("sample-pose", ("#p3",)))
    assert names.index(("test-traj", ())) > names.index(("plan-motion", ("#t1",)))


def test_a_valid_order_is_kept_and_every_order_is_made_valid() -> None:
    rng = random.Random(0)
    for _ in range(300):
        size = rng.randint(1, 12)
        entries = []
        for i in range(size):
            made_before = [f"#x{j}" for j in range(i)]
            inputs = tuple(rng.sample(made_before, k=min(len(made_before), rng.randint(0, 2))))
            context = tuple(("At", f"o{k}", x) for k, x in enumerate(
                rng.sample(made_before, k=min(len(made_before), rng.randint(0, 2)))))
            entries.append(_entry(f"s{i}", (*inputs, "real"), (f"#x{i}",), context))
        assert optimistic._after_their_contexts(list(entries)) == entries
        shuffled = list(entries)
        rng.shuffle(shuffled)
        ordered = optimistic._after_their_contexts(shuffled)
        assert sorted(map(repr, ordered)) == sorted(map(repr, entries))
        bound: set[str] = set()
        for key, outputs, context in ordered:
            needs = {*key[1], *(a for fact in context for a in fact[1:])}
            assert {x for x in needs if x.startswith("#")} <= bound
            bound.update(outputs)


def test_every_skeleton_binds_its_contexts_in_order(monkeypatch: pytest.MonkeyPatch) -> None:
    # kitchen_fluent adaptive seed 29 (fixed stream clock): the effort order put a motion
    # over real configurations before the samplers of the poses standing in its state; the
    # binding stopped there without a call and the same plan was searched again.
    bad: list[tuple[str, ...]] = []
    push = skeletons.BindingQueue.push

    def checked(queue: Any, binding: Any) -> None:
        skeleton = binding.skeleton
        made: dict[str, int] = {}
        for position, outputs in enumerate(skeleton.entry_outputs):
            for placeholder in outputs:
                made.setdefault(placeholder, position)
        for position, context in enumerate(skeleton.entry_contexts):
            if any(made.get(a, -1) > position for fact in context for a in fact[1:]):
                bad.append(skeleton.stream_plan[position])
        push(queue, binding)

    monkeypatch.setattr(skeletons.BindingQueue, "push", checked)
    run("adaptive", 29)
    assert not bad, bad
