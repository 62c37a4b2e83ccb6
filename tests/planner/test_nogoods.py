"""Nogoods of a stream plan: once a test (without ``:fluents``) of a skeleton failed, bindings
that give its inputs the same values are dropped rather than processed to it again."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest

from ltamp_cli.planner.algorithms import skeletons
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.algorithms.skeletons import Binding, BindingQueue, Skeleton
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"


def _skeleton() -> Skeleton:
    # pose of a -> #p0; conf of (a, #p0) -> #q1; pose of b -> #p2; test on (#q1, #p2).
    plan = (("sample", ("a",)), ("ik", ("a", "#p0")), ("sample", ("b",)),
            ("test", ("#q1", "#p2")))
    placeholders = {("sample", ("a",)): ("#p0",), ("ik", ("a", "#p0")): ("#q1",),
                    ("sample", ("b",)): ("#p2",), ("other", ("c",)): ("#x9",)}
    return Skeleton(plan, placeholders, ())


def test_nogood_covers_the_inputs_and_their_producers() -> None:
    skeleton = _skeleton()
    failed = {"#p0": "p-a", "#q1": "q-a", "#p2": "p-b"}
    skeleton.learn_nogood(3, failed)
    assert skeleton.nogoods == [(("#p0", "p-a"), ("#p2", "p-b"), ("#q1", "q-a"))]
    assert skeleton.doomed({**failed, "#x9": "anything"})
    assert not skeleton.doomed({**failed, "#p2": "other"})  # another sample of b
    assert not skeleton.doomed({"#p0": "p-a", "#q1": "q-a"})  # b not sampled yet


def test_queue_drops_doomed_bindings() -> None:
    skeleton = _skeleton()
    queue = BindingQueue()
    doomed = Binding(skeleton, 3, {"#p0": "p-a", "#q1": "q-a", "#p2": "p-b"})
    alive = Binding(skeleton, 3, {"#p0": "p-a", "#q1": "q-a", "#p2": "p-c"}, attempts=1)
    queue.push(doomed)
    queue.push(alive)
    assert queue.peek() is doomed
    skeleton.learn_nogood(3, dict(doomed.mapping))
    assert len(queue) == 1
    assert queue.pop() is alive


@pytest.mark.parametrize("seed", [1, 4])
def test_no_failed_test_is_reached_twice_by_one_skeleton(monkeypatch: pytest.MonkeyPatch,
                                                         seed: int) -> None:
    """kitchen_fluent: samplers that know nothing of each other make collision tests fail;
    before nogoods, alternatives of unrelated samplers walked to the same failed test again
    (seed 1: three times to the same one), spending the sampling share before a search."""
    reached: Counter[tuple[int, int, tuple[str, ...]]] = Counter()
    advance = skeletons.advance

    def recording(state, binding):  # type: ignore[no-untyped-def]
        children = advance(state, binding)
        plan = binding.skeleton.stream_plan
        if children is not None and binding.step < len(plan):
            name, inputs = plan[binding.step]
            real = tuple(binding.mapping.get(x, x) for x in inputs)
            if name == "test-cfree" and not state.instance(name, real).value:
                reached[(id(binding.skeleton), binding.step, real)] += 1
        return children

    monkeypatch.setattr(skeletons, "advance", recording)
    problem = load_problem(EXAMPLES / "kitchen_fluent.yaml")
    result = solve(problem, PlannerConfig(algorithm="adaptive", seed=seed, max_time=60))
    assert result.solved
    assert validate_plan(problem, result, check_stream_domains=False).valid
    assert reached, "no collision test failed: the test no longer exercises nogoods"
    assert max(reached.values()) == 1, reached.most_common(3)
