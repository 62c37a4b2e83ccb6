"""The grounding cache (:mod:`ltamp_cli.planner.search.incremental`) grounds each task of a
solve exactly as :func:`.ground_task` does from scratch: same actions and axioms in the
same order, same reachable facts, same blocked axioms, whatever facts come and go between
calls (static negative literals that appear later, effect conditions on static facts,
costs defined later, negative-only derived predicates whose bodies become reachable later).
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable
from dataclasses import fields
from pathlib import Path
from typing import Any

import pytest

from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import _solve
from ltamp_cli.planner.pddl.parse import parse_domain, parse_formula
from ltamp_cli.planner.pddl.sexpr import read_one
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.search import incremental
from ltamp_cli.planner.search.ground import Grounding, ground_task
from ltamp_cli.planner.search.incremental import GroundingCache
from ltamp_cli.planner.search.solve import plan_discrete
from ltamp_cli.planner.watchdog import CallTracker

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"

# Static negations (Broken, and Reserved through the derived UnsafeSlot), a forall (a
# negative-only auxiliary axiom), an effect conditioned on a static fact (Heavy), and a
# cost looked up in the function values (undefined: the action does not exist) and added to a
# constant one.
DOMAIN = """
(define (domain shelf)
  (:requirements :strips :derived-predicates :universal-preconditions
                 :conditional-effects :action-costs)
  (:predicates (Block ?b) (Pose ?b ?p) (AtPose ?b ?p) (Holding ?b) (CFree ?b ?p ?b2 ?p2)
               (Reserved ?p) (UnsafeSlot ?p) (Kin ?b ?p ?q) (Broken ?p) (Heavy ?b)
               (Tired) (HandEmpty))
  (:functions (PlaceCost ?b ?p))
  (:derived (UnsafeSlot ?p) (Reserved ?p))
  (:action place
    :parameters (?b ?p ?q)
    :precondition (and (Kin ?b ?p ?q) (Holding ?b) (not (UnsafeSlot ?p)) (not (Broken ?p))
                       (forall (?b2 ?p2) (imply (and (Pose ?b2 ?p2) (AtPose ?b2 ?p2))
                                                (CFree ?b ?p ?b2 ?p2))))
    :effect (and (AtPose ?b ?p) (not (Holding ?b)) (HandEmpty) (when (Heavy ?b) (Tired))
                 (increase (total-cost) (PlaceCost ?b ?p)) (increase (total-cost) 0.5)))
  (:action pick
    :parameters (?b ?p ?q)
    :precondition (and (Kin ?b ?p ?q) (AtPose ?b ?p) (HandEmpty))
    :effect (and (Holding ?b) (not (AtPose ?b ?p)) (not (HandEmpty)))))
"""
BLOCKS = ("a", "b", "c")
POSES = ("p1", "p2", "p3", "p4")


def _random_task(rng: random.Random) -> tuple[set[tuple[str, ...]], dict[tuple[str, ...], float]]:
    """An initial state over a fixed object universe, each optional fact drawn at random,
    and place costs defined for a random subset."""
    init: set[tuple[str, ...]] = {("handempty",)} if rng.random() < 0.7 else {("holding", "a")}
    for block in BLOCKS:
        init.add(("block", block))
        if rng.random() < 0.5:
            init.add(("heavy", block))
        home = rng.choice(POSES)
        init.add(("pose", block, home))
        if ("holding", block) not in init:
            init.add(("atpose", block, home))
        for pose in POSES:
            if rng.random() < 0.6:
                init.add(("pose", block, pose))
                init.add(("kin", block, pose, f"q{pose}"))
            for other in BLOCKS:
                for other_pose in POSES:
                    if other != block and rng.random() < 0.7:
                        init.add(("cfree", block, pose, other, other_pose))
    for pose in POSES:
        if rng.random() < 0.25:
            init.add(("reserved", pose))
        if rng.random() < 0.25:
            init.add(("broken", pose))
    costs = {("placecost", block, pose): float(rng.randint(1, 9))
             for block in BLOCKS for pose in POSES if rng.random() < 0.8}
    return init, costs


def _same(left: Grounding, right: Grounding) -> bool:
    return (left.actions == right.actions and left.axioms == right.axioms
            and left.reachable == right.reachable
            and left.static_predicates == right.static_predicates
            and left.derived_predicates == right.derived_predicates
            and sorted(left.blocked_axioms) == sorted(right.blocked_axioms))


def test_random_tasks_ground_as_from_scratch() -> None:
    domain = parse_domain(DOMAIN, "shelf.pddl")
    goal = parse_formula(read_one("(and (AtPose b p3) (Tired))", "goal.pddl", "the goal"))
    objects = {name: "object" for name in (*BLOCKS, *POSES, *(f"q{p}" for p in POSES))}
    rng = random.Random(3)
    cache = GroundingCache()
    differences = 0
    sizes = []
    for _ in range(40):
        init, costs = _random_task(rng)
        deadline = time.perf_counter() + 30
        cached = plan_discrete(domain, objects, init, costs, goal, deadline,
                               grounding_cache=cache)
        scratch = plan_discrete(domain, objects, init, costs, goal, deadline)
        differences += not _same(cached.grounding, scratch.grounding)
        assert cached.actions == scratch.actions
        sizes.append(len(scratch.grounding.actions))
    assert differences == 0
    # The tasks differ (else this tests nothing) and were grounded from one union.
    assert len(set(sizes)) > 5 and cache.calls == 40 and cache.resets == 0


def test_a_negative_only_axiom_whose_body_arrives_later() -> None:
    """The forall's auxiliary axiom for (a, p1) is demanded in the first task, but its body
    fact (a colliding block standing at pb) exists only in the next one: the union must
    ground it then (a first version of the cache missed it)."""
    domain = parse_domain(DOMAIN, "shelf.pddl")
    goal = parse_formula(read_one("(AtPose a p1)", "goal.pddl", "the goal"))
    objects = {name: "object" for name in ("a", "b", "p1", "pb", "q1")}
    first = {("holding", "a"), ("block", "a"), ("kin", "a", "p1", "q1"), ("pose", "a", "p1")}
    second = first | {("block", "b"), ("pose", "b", "pb"), ("atpose", "b", "pb")}
    costs = {("placecost", "a", "p1"): 1.0}
    cache = GroundingCache()
    results = []
    # (The first task of a rule set is grounded from scratch, the union built on the second.)
    for init in (first, first, second, first, second):
        deadline = time.perf_counter() + 30
        cached = plan_discrete(domain, objects, init, costs, goal, deadline,
                               grounding_cache=cache)
        scratch = plan_discrete(domain, objects, init, costs, goal, deadline)
        assert _same(cached.grounding, scratch.grounding)
        results.append(cached.solved)
    # b at pb is not known collision-free with a at p1: placing is forbidden then.
    assert results == [True, True, False, True, False]


def _checked(calls: list[bool]) -> Callable[..., Grounding]:
    original = GroundingCache.ground

    def ground(self: GroundingCache, actions: Any, axioms: Any, init: Any,
               function_values: Any, deadline: float) -> Grounding:
        init = set(init)
        result = original(self, actions, axioms, init, function_values, deadline)
        calls.append(_same(result, ground_task(actions, axioms, init, function_values,
                                               deadline)))
        return result
    return ground


@pytest.mark.parametrize("example,algorithm", [("kitchen_fluent", "adaptive"),
                                               ("tamp2d_uniform_tight_2", "adaptive"),
                                               ("tamp2d_4blocks", "binding")])
def test_whole_solves_ground_as_from_scratch(example: str, algorithm: str,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    problem = load_problem(EXAMPLES / f"{example}.yaml")
    calls: list[bool] = []
    monkeypatch.setattr(incremental.GroundingCache, "ground", _checked(calls))
    known = {f.name for f in fields(PlannerConfig)}
    options = {k: v for k, v in problem.planner_options.items() if k in known}
    config = PlannerConfig(**{**options, "algorithm": algorithm, "seed": 0,
                              "max_time": 60.0, "incremental_grounding": True})
    result = _solve(problem, config, time.perf_counter(), CallTracker(), [])
    assert result.status == "solved"
    assert len(calls) >= 3 and all(calls)
