"""Derived predicates used only negatively (the auxiliary predicate of a ``forall``
precondition, or a user's ``UnsafePose``) are grounded for the instances that grounded
actions negate, not for every tuple of objects, and keep their meaning."""

from __future__ import annotations

import time

import pytest

from ltamp_cli.planner.pddl.parse import parse_domain, parse_formula
from ltamp_cli.planner.pddl.sexpr import read_one
from ltamp_cli.planner.search.solve import plan_discrete

# Placing a block needs every standing block to be collision-free with the new pose (the
# forall of PDDLStream's continuous_tamp); UnsafeSlot is a derived predicate used only
# negatively, written by the user.
DOMAIN = """
(define (domain shelf)
  (:requirements :strips :derived-predicates :universal-preconditions)
  (:predicates (Block ?b) (Pose ?b ?p) (AtPose ?b ?p) (Holding ?b) (CFree ?b ?p ?b2 ?p2)
               (Reserved ?p) (UnsafeSlot ?p) (Kin ?b ?p ?q))
  (:derived (UnsafeSlot ?p) (Reserved ?p))
  (:action place
    :parameters (?b ?p ?q)
    :precondition (and (Kin ?b ?p ?q) (Holding ?b) (not (UnsafeSlot ?p))
                       (forall (?b2 ?p2) (imply (and (Pose ?b2 ?p2) (AtPose ?b2 ?p2))
                                                (CFree ?b ?p ?b2 ?p2))))
    :effect (and (AtPose ?b ?p) (not (Holding ?b)))))
"""


def _problem(n_filler: int, cfree_goal_pose: bool) -> tuple[dict[str, str], set[tuple[str, ...]]]:
    """Block ``a`` is held and may go to ``p1`` or ``p2``; ``b`` stands at ``pb``.
    ``p2`` is reserved; ``p1`` is collision-free with ``pb`` only if ``cfree_goal_pose``.
    ``n_filler`` unrelated objects inflate the object universe."""
    objects = {name: "object" for name in ("a", "b", "p1", "p2", "pb", "q1", "q2")}
    objects.update({f"x{i}": "object" for i in range(n_filler)})
    init = {("Block", "a"), ("Block", "b"), ("Holding", "a"), ("Pose", "b", "pb"),
            ("AtPose", "b", "pb"), ("Pose", "a", "p1"), ("Pose", "a", "p2"),
            ("Kin", "a", "p1", "q1"), ("Kin", "a", "p2", "q2"), ("Reserved", "p2"),
            ("CFree", "a", "p2", "b", "pb")}
    if cfree_goal_pose:
        init.add(("CFree", "a", "p1", "b", "pb"))
    return objects, {(fact[0].lower(), *fact[1:]) for fact in init}  # names are case-folded


def _solve(n_filler: int, cfree_goal_pose: bool, goal: str):  # type: ignore[no-untyped-def]
    domain = parse_domain(DOMAIN, "shelf.pddl")
    objects, init = _problem(n_filler, cfree_goal_pose)
    formula = parse_formula(read_one(goal, "goal.pddl", "the goal"))
    return plan_discrete(domain, objects, init, {}, formula, time.perf_counter() + 30)


@pytest.mark.parametrize("n_filler", [0, 300])
def test_forall_and_negated_derived_keep_their_meaning(n_filler: int) -> None:
    placed = _solve(n_filler, cfree_goal_pose=True, goal="(AtPose a p1)")
    assert placed.solved and [str(a) for a in placed.actions or []] == ["(place a p1 q1)"]
    # p1 collides with b: the forall forbids it.
    assert not _solve(n_filler, cfree_goal_pose=False, goal="(AtPose a p1)").solved
    # p2 is collision-free but reserved: the negated derived predicate forbids it.
    assert not _solve(n_filler, cfree_goal_pose=True, goal="(AtPose a p2)").solved


def test_negative_only_axioms_are_grounded_for_the_negated_instances_only() -> None:
    result = _solve(300, cfree_goal_pose=True, goal="(AtPose a p1)")
    heads = {axiom.head for axiom in result.grounding.axioms}
    forall_heads = {head for head in heads if head[0].startswith("%forall")}
    # One instance per place action (a, p1) and (a, p2), not one per pair of the 307
    # objects (94,249): the place precondition has no static literal over (?b ?p) alone.
    assert {head[1:] for head in forall_heads} <= {("a", "p1"), ("a", "p2")}
    assert {head for head in heads if head[0] == "unsafeslot"} <= {("unsafeslot", "p2")}
