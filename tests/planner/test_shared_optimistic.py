"""Shared optimistic outputs (PDDLStream's ``PartialInputs``, issue #19).

A domain shaped like kitchen_fluent's growth: ``n`` objects each get a placeholder pose
(``sample-pose`` over a real object), each placeholder pose a configuration for each of
``m`` hands (``ik``, like kitchen_fluent's ``skill-conf`` per tool), and a test connects
every pair of configurations (``reach``, like the motions). Without sharing, the optimistic
task holds ``n * m`` placeholder configurations and ``(n * m + 1)**2`` reach facts.
"""

from __future__ import annotations

import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import PlannerConfig, initial_state
from ltamp_cli.planner.algorithms.optimistic import Placeholders, optimistic_evaluation
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
    :inputs (?h ?o ?p)
    :domain (and (Hand ?h) (Pose ?o ?p))
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
    def ik(h, o, p):
        yield (("conf", o, p[2]),)
    ik_info = StreamInfo(opt_gen_fn=None if world["policy"] is None
                         else PartialInputs(**world["policy"]))
    return {"sample-pose": sample_pose, "ik": Binding(ik, ik_info),
            "reach": lambda q1, q2: True}
"""


def touch_problem(make_problem, n: int, policy: str = "null", hands: int = 1) -> PlanningProblem:  # type: ignore[no-untyped-def]
    objects = [f"o{i}" for i in range(n)]
    init = ", ".join([*(f'"(Obj {o})"' for o in objects), '"(Conf home)"', '"(AtConf home)"',
                      *(f'"(Hand h{i})"' for i in range(hands))])
    names = [*objects, *(f"h{i}" for i in range(hands))]
    goal = "(and " + " ".join(f"(Touched {o})" for o in objects) + ")"
    path = make_problem(DOMAIN,
                        f"domain: dom\nbindings: bindings.py\nworld: {{policy: {policy}}}\n"
                        f"objects: {{home: home, {', '.join(f'{o}: null' for o in names)}}}\n"
                        f"init: [{init}]\ngoal: {goal}\n",
                        STREAMS, BINDINGS, name=f"touch{n}_{hands}.yaml")
    return load_problem(path)


def optimistic_size(problem: PlanningProblem) -> tuple[int, int]:
    """(placeholder configurations, reach facts) of the first optimistic evaluation."""
    state = initial_state(problem, PlannerConfig(seed=0))
    evaluation = optimistic_evaluation(state, 10, Placeholders())
    facts = evaluation.index.members
    confs = [f for f in facts if f[0] == "conf" and f[1].startswith("#")]
    return len(confs), sum(1 for f in facts if f[0] == "reach")


def test_optimistic_task_does_not_grow_with_real_inputs_beside_a_placeholder(make_problem) -> None:  # type: ignore[no-untyped-def]
    # 3 objects, each with one placeholder pose, and 2 or 6 hands: 6 or 18 ik instances over
    # placeholder poses. By default they share one configuration per placeholder pose: 3
    # either way (and (3 + 1)**2 reach facts), where one per instance gives 18 (and 19**2).
    assert optimistic_size(touch_problem(make_problem, 3, hands=2)) == (3, 16)
    assert optimistic_size(touch_problem(make_problem, 3, hands=6)) == (3, 16)
    assert optimistic_size(touch_problem(make_problem, 3, "{unique: true}", hands=6)) == (
        18, 19 ** 2)
    # Instances whose placeholder inputs differ keep their own: one per object here.
    assert optimistic_size(touch_problem(make_problem, 5, hands=1)) == (5, 36)


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
    assert [sorted(key[1][1] for key in keys if key[0] == "ik") for keys in refined] == [
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
