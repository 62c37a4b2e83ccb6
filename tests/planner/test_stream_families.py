"""Stream families (``algorithms/families.py``): a hope that fails for every sample of a
generator stops being renewed by each fresh sample, and pending instances over sampled
values stop multiplying the optimistic task.

The synthetic *reach* domain: an item on a line must end in the goal region. Arm ``near``
reaches the start and the middle, arm ``far`` the middle and the goal; kinematics
(``kin``) fails out of reach. The cheapest optimistic plan has ``near`` carry the item
straight into the goal (two actions); every pose sampled there makes a new ``kin(near,
item, pose)`` instance, which fails. The plan that works hands the item over in the middle
(four actions)."""

from __future__ import annotations

from pathlib import Path

import pytest

from ltamp_cli.planner.algorithms.common import PlannerConfig, initial_state
from ltamp_cli.planner.algorithms.families import (
    FAMILY_MIN_FAILURES,
    MAX_PENALTY,
    WILDCARD,
    StreamFamilies,
)
from ltamp_cli.planner.algorithms.optimistic import (
    MAX_UNIQUE_OVER_SAMPLES,
    Placeholders,
    feeding_generators,
    optimistic_evaluation,
)
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"

REACH_DOMAIN = """
(define (domain reach)
  (:requirements :strips :derived-predicates :action-costs)
  (:predicates (Arm ?a) (Item ?i) (Region ?r) (Pose ?i ?p) (In ?i ?p ?r) (Grasp ?i ?g)
               (Kin ?a ?i ?p ?g ?q)
               (AtPose ?i ?p) (Holding ?a ?i ?g) (Free ?a) (Inside ?i ?r))
  (:functions (total-cost))
  (:derived (Inside ?i ?r) (exists (?p) (and (In ?i ?p ?r) (AtPose ?i ?p))))
  (:action pick
    :parameters (?a ?i ?p ?g ?q)
    :precondition (and (Kin ?a ?i ?p ?g ?q) (AtPose ?i ?p) (Free ?a))
    :effect (and (Holding ?a ?i ?g) (not (AtPose ?i ?p)) (not (Free ?a))
                 (increase (total-cost) 1)))
  (:action place
    :parameters (?a ?i ?p ?g ?q)
    :precondition (and (Kin ?a ?i ?p ?g ?q) (Holding ?a ?i ?g))
    :effect (and (AtPose ?i ?p) (Free ?a) (not (Holding ?a ?i ?g))
                 (increase (total-cost) 1))))
"""
REACH_STREAMS = """
(define (stream reach)
  (:stream sample-pose
    :inputs (?i ?r)
    :domain (and (Item ?i) (Region ?r))
    :outputs (?p)
    :certified (and (Pose ?i ?p) (In ?i ?p ?r)))
  (:stream sample-grasp
    :inputs (?i)
    :domain (Item ?i)
    :outputs (?g)
    :certified (Grasp ?i ?g))
  (:stream kin
    :inputs (?a ?i ?p ?g)
    :domain (and (Arm ?a) (Pose ?i ?p) (Grasp ?i ?g))
    :outputs (?q)
    :certified (Kin ?a ?i ?p ?g ?q)))
"""
REACH_BINDINGS = """
def make_streams(world, rng):
    regions = {"start": (0.0, 4.0), "middle": (4.5, 5.5), "goal": (6.5, 10.0)}
    reach = {"near": (0.0, 6.0), "far": (4.0, 10.0)}

    def sample_pose(item, region):
        low, high = regions[region]
        while True:
            yield (float(rng.uniform(low, high)),)

    def sample_grasp(item):
        while True:
            yield (float(rng.uniform(-0.1, 0.1)),)

    def kin(arm, item, pose, grasp):
        low, high = reach[arm]
        return ((arm, round(pose + grasp, 6)),) if low <= pose + grasp <= high else None

    return {"sample-pose": sample_pose, "sample-grasp": sample_grasp, "kin": kin}
"""
REACH_PROBLEM = """
name: reach
domain: dom
bindings: bindings.py
objects: {near: null, far: null, item: null, p0: 1.0, start: null, middle: null,
          goal: null}
init:
  - (Arm near)
  - (Arm far)
  - (Free near)
  - (Free far)
  - (Item item)
  - (Region start)
  - (Region middle)
  - (Region goal)
  - (Pose item p0)
  - (In item p0 start)
  - (AtPose item p0)
goal: (Inside item goal)
"""


def _reach(make_problem) -> Path:
    return make_problem(REACH_DOMAIN, REACH_PROBLEM, REACH_STREAMS, REACH_BINDINGS)


@pytest.mark.parametrize("algorithm", ["adaptive", "binding"])
@pytest.mark.parametrize("seed", [0, 5])
def test_a_failing_family_is_not_renewed_by_each_sample(make_problem, algorithm: str,
                                                         seed: int) -> None:
    """Failed on main: adaptive timed out (60 s: 430-540 searches, 440-550 failed ``kin``
    calls, each new grasp or goal pose renewing the plan that carries the item straight
    into the goal); binding solved it in 15 searches. Now 10-13 and 8."""
    problem = load_problem(_reach(make_problem))
    result = solve(problem, PlannerConfig(algorithm=algorithm, seed=seed, max_time=20))
    assert result.solved, result.status
    assert validate_plan(problem, result, check_stream_domains=False).valid
    assert [step.name for step in result.plan] == ["pick", "place", "pick", "place"]
    assert result.stats["searches"] <= 20, result.stats["searches"]
    kin = result.stats["streams"]["kin"]
    assert kin["calls"] - kin["successes"] <= 12, kin


def test_families_describe_sampled_inputs_by_origin_and_by_value() -> None:
    """Coarse to fine: a sampled input by its origin, then by itself."""
    objects = {"near": None, "item": None, "goal": None}
    families = StreamFamilies()
    families.record("sample-pose", ("item", "goal"), True, [("@p1",), ("@p2",)], objects)
    origin = ("sample-pose", ("item", "goal"))
    assert families.families("kin", ("near", "item", "@p1"), objects) == [
        ("kin", ("near", "item", origin)), ("kin", ("near", "item", "@p1"))]
    # A placeholder is described by its producer's origin only; unknown values by "*".
    assert families.families("kin", ("near", "item", "#p7"), objects,
                             lambda x: origin if x == "#p7" else None) == [
        ("kin", ("near", "item", origin))]
    assert families.families("kin", ("near", "item", "#p8"), objects) == [
        ("kin", ("near", "item", WILDCARD))]


def test_the_penalty_needs_failures_without_a_success_and_is_bounded() -> None:
    objects = {"near": None, "far": None, "item": None, "goal": None}
    families = StreamFamilies()
    families.record("sample-pose", ("item", "goal"), True,
                    [(f"@p{i}",) for i in range(40)], objects)
    for i in range(FAMILY_MIN_FAILURES - 1):
        families.record("kin", ("near", "item", f"@p{i}"), False, [], objects)
    fresh = ("near", "item", "@p39")
    assert families.instance_penalty("kin", fresh, objects) == 0
    families.record("kin", ("near", "item", "@p30"), False, [], objects)
    first = families.instance_penalty("kin", fresh, objects)
    assert first > 0
    for i in range(FAMILY_MIN_FAILURES, 30):
        families.record("kin", ("near", "item", f"@p{i}"), False, [], objects)
    assert first < families.instance_penalty("kin", fresh, objects) == MAX_PENALTY
    # Another arm, or the same arm once it succeeded in the family: no penalty.
    assert families.instance_penalty("kin", ("far", "item", "@p39"), objects) == 0
    families.record("kin", ("near", "item", "@p31"), True, [("@q",)], objects)
    assert families.instance_penalty("kin", ("near", "item", "@p38"), objects) == 0


def test_the_penalty_is_left_out_at_the_limit(make_problem) -> None:
    """At the complexity limit (where "infeasible" is decided) a penalised family's
    instances are admitted as before: the penalty reorders, it never proves."""
    problem = load_problem(_reach(make_problem))
    state = initial_state(problem, PlannerConfig(algorithm="adaptive", seed=0))
    grasps = state.instance("sample-grasp", ("item",))
    state.call(grasps)
    for _ in range(3 * FAMILY_MIN_FAILURES):
        instance = state.instance("sample-pose", ("item", "goal"))
        state.call(instance)
        pose = instance.results[-1][0]
        state.call(state.instance("kin", ("near", "item", pose, grasps.results[0][0])))
    assert state.families.has_failing("kin")
    placeholders = Placeholders()
    goal_sampler = ("sample-pose", ("item", "goal"))

    def near_goal(evaluation) -> list[object]:
        return [key for key in evaluation.outputs if key[0] == "kin" and key[1][0] == "near"
                and (evaluation.object_producer.get(key[1][2]) == goal_sampler
                     or state.families.origins.get(key[1][2]) == goal_sampler)]

    assert not near_goal(optimistic_evaluation(state, 3, placeholders))
    limit = state.config.max_complexity + state.max_object_level()
    assert near_goal(optimistic_evaluation(state, limit, placeholders))


def test_instances_over_samples_beyond_the_limit_wait_for_a_higher_bound() -> None:
    """Pending instances over sampled values of a generator whose outputs feed other
    streams (kinematics -> motions): the first MAX_UNIQUE_OVER_SAMPLES of the stream are
    admitted at their level, the others later (each sample multiplied them, and the
    motions between their outputs: the hidden suite's handoff_2, 198 kinematics and
    23,086 motion placeholders). Motions feed nothing and are not limited."""
    problem = load_problem(EXAMPLES / "tamp2d_uniform_tight_2.yaml")
    assert feeding_generators(problem.stream_file.streams) == {
        "sample-pose", "sample-grasp", "inverse-kinematics"}
    state = initial_state(problem, PlannerConfig(algorithm="adaptive", seed=0))
    grasps = state.instance("sample-grasp", ("a",))
    state.call(grasps)
    poses = state.instance("sample-pose", ("a", "table"))
    for _ in range(MAX_UNIQUE_OVER_SAMPLES + 8):
        state.call(poses)
    assert len(poses.results) > MAX_UNIQUE_OVER_SAMPLES
    placeholders = Placeholders()
    evaluation = optimistic_evaluation(state, 1, placeholders)
    real = [key for key in evaluation.outputs if key[0] == "inverse-kinematics"
            and not any(x.startswith("#") for x in key[1])]
    assert len(real) == MAX_UNIQUE_OVER_SAMPLES
    higher = optimistic_evaluation(state, 3, placeholders)
    assert len([key for key in higher.outputs if key[0] == "inverse-kinematics"
                and not any(x.startswith("#") for x in key[1])]) == len(poses.results) + 1
