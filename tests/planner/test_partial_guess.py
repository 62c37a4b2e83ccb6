"""The guess checked before a speculative search: a half-bound optimistic plan rebased onto
the new optimistic task (see :func:`ltamp_cli.planner.algorithms.skeletons.partial_guess`)."""

from __future__ import annotations

from types import SimpleNamespace

from ltamp_cli.planner.algorithms.optimistic import OptimisticEvaluation
from ltamp_cli.planner.algorithms.skeletons import Binding, Skeleton, partial_guess
from ltamp_cli.planner.search.ground import FactIndex

# pose of the cup -> kinematics for that pose -> motion from home to that configuration
PLAN = (("sample-pose", ("cup",)), ("ik", ("cup", "#p0")), ("motion", ("home", "#q1")))
PLACEHOLDERS = {PLAN[0]: ("#p0",), PLAN[1]: ("#q1",), PLAN[2]: ("#t2",)}
STEPS = (("move", ("home", "#t2", "#q1")), ("pick", ("cup", "#p0", "#q1")))


def _binding() -> Binding:
    """The pose is sampled (``#p0`` is ``@p5``); kinematics and motion are not called."""
    skeleton = Skeleton(PLAN, PLACEHOLDERS, (), steps=STEPS)
    return Binding(skeleton, step=1, mapping={"#p0": "@p5"})


def _evaluation(outputs: dict) -> OptimisticEvaluation:
    return OptimisticEvaluation(FactIndex(), {}, {}, outputs=outputs)


def test_outputs_of_rebound_instances_take_the_new_placeholders() -> None:
    # In the new task, ik over the sampled pose is its own instance, with its own output,
    # and the motion to that output is another instance again.
    evaluation = _evaluation({("ik", ("cup", "@p5")): ("#q7",),
                              ("motion", ("home", "#q7")): ("#t8",)})
    guess = partial_guess(SimpleNamespace(instances={}), _binding(), evaluation)
    assert guess == [("move", ("home", "#t8", "#q7")), ("pick", ("cup", "@p5", "#q7"))]


def test_an_instance_another_binding_called_gives_its_first_output() -> None:
    called = SimpleNamespace(results=[("@q3",), ("@q4",)])
    evaluation = _evaluation({("motion", ("home", "@q3")): ("#t9",)})
    state = SimpleNamespace(instances={("ik", ("cup", "@p5")): called})
    guess = partial_guess(state, _binding(), evaluation)
    assert guess == [("move", ("home", "#t9", "@q3")), ("pick", ("cup", "@p5", "@q3"))]


def test_unknown_instances_keep_their_placeholders() -> None:
    guess = partial_guess(SimpleNamespace(instances={}), _binding(), _evaluation({}))
    assert guess == [("move", ("home", "#t2", "#q1")), ("pick", ("cup", "@p5", "#q1"))]
