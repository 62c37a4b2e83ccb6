"""Shared optimistic outputs (PDDLStream's ``PartialInputs``, issue #19).

A domain shaped like kitchen_fluent's growth: ``n`` objects each get a placeholder pose
(``sample-pose`` over a real object), each placeholder pose a configuration (``ik``), and a
test connects every pair of configurations (``reach``, like the motions). Without sharing,
the optimistic task holds ``n`` placeholder configurations and ``(n + 1)**2`` reach facts.
"""

from __future__ import annotations

import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import PlannerConfig, initial_state
from ltamp_cli.planner.algorithms.optimistic import (
    UNSHARED_PER_STREAM,
    Placeholders,
    optimistic_evaluation,
)
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import PlanningProblem, load_problem
from ltamp_cli.planner.validate import validate_plan

DOMAIN = """
(define (domain touch)
  (:predicates (Obj ?o) (Pose ?o ?p) (Conf ?q) (Kin ?o ?p ?q) (Reach ?q1 ?q2)
               (AtConf ?q) (Touched ?o))
  (:action move
    :parameters (?q1 ?q2)
    :precondition (and (AtConf ?q1) (Reach ?q1 ?q2))
    :effect (and (AtConf ?q2) (not (AtConf ?q1))))
  (:action touch
    :parameters (?o ?p ?q)
    :precondition (and (Kin ?o ?p ?q) (AtConf ?q))
    :effect (Touched ?o)))
"""
STREAMS = """
(define (stream touch)
  (:stream sample-pose
    :inputs (?o)
    :domain (Obj ?o)
    :outputs (?p)
    :certified (Pose ?o ?p))
  (:stream ik
    :inputs (?o ?p)
    :domain (Pose ?o ?p)
    :outputs (?q)
    :certified (and (Conf ?q) (Kin ?o ?p ?q)))
  (:stream reach
    :inputs (?q1 ?q2)
    :domain (and (Conf ?q1) (Conf ?q2))
    :certified (Reach ?q1 ?q2)))
"""
# Poses and configurations are (kind, object, index) tuples: every object's configuration
# differs, so a plan that touched two objects from one shared configuration cannot bind.
BINDINGS = """
from ltamp_cli.planner.streams import Binding, PartialInputs, StreamInfo

def make_streams(world, rng):
    def sample_pose(o):
        for i in range(3):
            yield (("pose", o, i),)
    def ik(o, p):
        yield (("conf", o, p[2]),)
    ik_info = StreamInfo(opt_gen_fn=None if world["policy"] is None
                         else PartialInputs(**world["policy"]))
    return {"sample-pose": sample_pose, "ik": Binding(ik, ik_info),
            "reach": lambda q1, q2: True}
"""


def touch_problem(make_problem, n: int, policy: str = "null") -> PlanningProblem:  # type: ignore[no-untyped-def]
    objects = [f"o{i}" for i in range(n)]
    init = ", ".join([*(f'"(Obj {o})"' for o in objects), '"(Conf home)"', '"(AtConf home)"'])
    goal = "(and " + " ".join(f"(Touched {o})" for o in objects) + ")"
    path = make_problem(DOMAIN,
                        f"domain: dom\nbindings: bindings.py\nworld: {{policy: {policy}}}\n"
                        f"objects: {{home: home, {', '.join(f'{o}: null' for o in objects)}}}\n"
                        f"init: [{init}]\ngoal: {goal}\n",
                        STREAMS, BINDINGS, name=f"touch{n}.yaml")
    return load_problem(path)


def optimistic_size(problem: PlanningProblem) -> tuple[int, int]:
    """(placeholder configurations, reach facts) of the first optimistic evaluation."""
    state = initial_state(problem, PlannerConfig(seed=0))
    evaluation = optimistic_evaluation(state, 10, Placeholders())
    facts = evaluation.index.members
    confs = [f for f in facts if f[0] == "conf" and f[1].startswith("#")]
    return len(confs), sum(1 for f in facts if f[0] == "reach")


def test_optimistic_task_does_not_grow_with_the_optimistic_inputs(make_problem) -> None:  # type: ignore[no-untyped-def]
    # 20 and 30 objects: 20 and 30 placeholder poses feed ik. Unshared, the task had 20 and
    # 30 placeholder configurations and 441 and 961 reach facts. By default the first
    # UNSHARED_PER_STREAM instances keep their own, the others share one.
    assert UNSHARED_PER_STREAM < 20
    small = optimistic_size(touch_problem(make_problem, 20))
    large = optimistic_size(touch_problem(make_problem, 30))
    confs = UNSHARED_PER_STREAM + 1
    assert small == large == (confs, (confs + 1) ** 2)
    # Below that many, nothing is shared (small tasks stay as they were).
    assert optimistic_size(touch_problem(make_problem, 3)) == (3, 16)


def test_unique_policy_keeps_one_output_per_instance(make_problem) -> None:  # type: ignore[no-untyped-def]
    # StreamInfo(opt_gen_fn=PartialInputs(unique=True)): PDDLStream's per-instance outputs.
    assert optimistic_size(touch_problem(make_problem, 4, "{unique: true}")) == (4, 25)
    # Shared per value of ?o: one per object, as many as the objects.
    assert optimistic_size(touch_problem(make_problem, 4, "{inputs: '?o'}")) == (4, 25)
    # Shared per value of ?p only is the same here (one placeholder pose per object).
    assert optimistic_size(touch_problem(make_problem, 4, "{inputs: '?p'}")) == (4, 25)
    # PartialInputs("") shares across every instance from the first.
    assert optimistic_size(touch_problem(make_problem, 4, "{inputs: ''}")) == (1, 4)


@pytest.mark.parametrize("algorithm", ["adaptive", "binding", "focused"])
def test_a_plan_over_one_shared_output_is_refined_before_binding(make_problem, monkeypatch,  # type: ignore[no-untyped-def]
                                                                 algorithm: str) -> None:
    # The first optimistic plan touches every object from the one shared configuration;
    # binding it would use one object's configuration for the others. It must be refined
    # (each object's ik instance gets its own placeholder) and the plan move between them.
    from ltamp_cli.planner.algorithms import optimistic

    refined: list[list[tuple[str, tuple[str, ...]]]] = []
    original = optimistic._refine

    def spy(state, placeholders, keys):  # type: ignore[no-untyped-def]
        refined.append(list(keys))
        original(state, placeholders, keys)

    monkeypatch.setattr(optimistic, "_refine", spy)
    # PDDLStream's default, PartialInputs(): one configuration shared by every ik instance.
    problem = touch_problem(make_problem, 3, "{inputs: ''}")
    result = solve(problem, PlannerConfig(algorithm=algorithm, seed=0, max_time=20))
    assert result.solved
    assert [sorted(key[1][0] for key in keys if key[0] == "ik") for keys in refined] == [
        ["o0", "o1", "o2"]]
    assert validate_plan(problem, result).valid
    touches = [step for step in result.plan if step.name == "touch"]
    assert sorted(step.values[0] for step in touches) == ["o0", "o1", "o2"]
    for step in touches:  # each touched from its own object's configuration
        assert step.values[2][:2] == ("conf", step.values[0])
    assert sum(step.name == "move" for step in result.plan) >= 3


def test_partial_inputs_must_name_inputs_of_the_stream(make_problem) -> None:  # type: ignore[no-untyped-def]
    problem = touch_problem(make_problem, 2, "{inputs: '?x'}")
    with pytest.raises(InputError, match=r"names no input of it"):
        solve(problem, PlannerConfig(seed=0, max_time=5))


def test_pddlstream_stream_info_sets_the_policy() -> None:
    from ltamp_cli.pddlstream import PartialInputs as PDDLStreamPartialInputs
    from ltamp_cli.pddlstream import StreamInfo as PDDLStreamInfo
    from ltamp_cli.pddlstream.problem import _planner_info
    from ltamp_cli.planner.streams import PartialInputs

    info = _planner_info(PDDLStreamInfo(opt_gen_fn=PDDLStreamPartialInputs("?o")))
    assert info.opt_gen_fn == PartialInputs("?o", unique=False)
    assert _planner_info(PDDLStreamInfo()).opt_gen_fn is None
    # A custom optimistic generator is not called: one placeholder per instance instead.
    custom = _planner_info(PDDLStreamInfo(opt_gen_fn=lambda *values: iter([[("x",)]])))
    assert custom.opt_gen_fn == PartialInputs(unique=True)
