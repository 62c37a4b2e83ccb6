"""A test fact a formula needs false, as PDDLStream plans with it (its negated streams).

Before the fix, ``(not (Collide ...))`` held for values the collision test had never seen:
every algorithm placed the second box on the first one without calling the test.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

import redteam_problems as problems

from ltamp_cli.pddlstream import solve
from ltamp_cli.pddlstream.problem import to_planning_problem
from ltamp_cli.planner.algorithms.common import ALGORITHMS, PlannerConfig
from ltamp_cli.planner.api import solve as plan
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

DERIVED = ("""(forall (?b2 ?x2) (imply (AtPos ?b2 ?x2)
                                                (not (Collide ?b ?x ?b2 ?x2))))""",
           "(not (Blocked ?b ?x))")
BLOCKED_AXIOM = """(:derived (Blocked ?b ?x)
    (exists (?b2 ?x2) (and (Pos ?b ?x) (AtPos ?b2 ?x2) (Collide ?b ?x ?b2 ?x2))))
  (:action place"""


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_negated_collision_test_in_forall_is_called(tmp_path: Path, algorithm: str) -> None:
    problem, check = problems.conveyor_problem(tmp_path, seed=0)
    solution = solve(problem, algorithm=algorithm, max_time=20, verbose=False)
    assert solution.plan is not None, algorithm
    check(solution.plan)  # the two boxes do not overlap


@pytest.mark.parametrize("algorithm", ("adaptive", "incremental"))
def test_negated_test_through_a_derived_predicate(tmp_path: Path, algorithm: str,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    domain = problems.CONVEYOR_DOMAIN.replace(*DERIVED).replace("(:action place",
                                                                 BLOCKED_AXIOM, 1)
    assert "Blocked" in domain
    monkeypatch.setattr(problems, "CONVEYOR_DOMAIN", domain)
    problem, check = problems.conveyor_problem(tmp_path, seed=0)
    planning = to_planning_problem(problem)
    result = plan(planning, PlannerConfig(algorithm=algorithm, max_time=20))
    assert result.solved and result.plan is not None
    assert validate_plan(planning, result).valid
    solution = solve(problem, algorithm=algorithm, max_time=20, verbose=False)
    assert solution.plan is not None
    check(solution.plan)


def test_validator_rejects_an_untested_negation(tmp_path: Path) -> None:
    """The validator calls the test for a negated fact: a plan whose boxes overlap is
    invalid even though no certificate mentions the collision."""
    problem, _ = problems.conveyor_problem(tmp_path, seed=0)
    planning = to_planning_problem(problem)
    result = plan(planning, PlannerConfig(algorithm="incremental", max_time=20))
    assert result.solved and result.plan is not None
    places = [step for step in result.plan if step.name == "place"]
    assert len(places) == 2
    # move the second box onto the first one's position, and its certificate with it
    first, second = places[0].args[1], places[1].args[1]
    forged = [f for f in result.certificate.facts if f[0] == "~collide"]
    assert forged, "the negated test's result is in the certificate"
    result.objects[second] = result.objects[first]
    assert not validate_plan(planning, result).valid


def test_shipped_domains_unchanged() -> None:
    """Shipped domains write their tests positively (tamp2d's CFree under a negated
    derived predicate): nothing is added to them."""
    for name in ("examples/tamp2d_4blocks", "examples/kitchen_fluent"):
        loaded = load_problem(name)
        assert loaded.stream_file is not None
        assert not any(s.negates for s in loaded.stream_file.streams), name
        assert not any(a.head.name.endswith(("~t", "~f")) for a in loaded.domain.axioms)


PREDICATE_STREAMS = """
(define (stream conveyor)
  (:stream sample-pos
    :inputs (?b) :domain (Box ?b)
    :outputs (?x) :certified (Pos ?b ?x))
  (:predicate (Collide ?b ?x ?b2 ?x2) (and (Pos ?b ?x) (Pos ?b2 ?x2))))
"""


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_negated_external_predicate(tmp_path: Path, algorithm: str,
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """The same with Collide a :predicate (evaluated lazily): also never assumed false."""
    monkeypatch.setattr(problems, "CONVEYOR_STREAMS", PREDICATE_STREAMS)
    problem, check = problems.conveyor_problem(tmp_path, seed=0)
    stream_map = {"sample-pos": problem.stream_map["sample-pos"],
                  "Collide": problem.stream_map["test-collide"]}
    solution = solve(problem._replace(stream_map=stream_map), algorithm=algorithm,
                     max_time=20, verbose=False)
    assert solution.plan is not None
    check(solution.plan)
