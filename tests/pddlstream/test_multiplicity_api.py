"""The drop-in API on a plan that needs two distinct outputs of one generator instance:
solved by every algorithm (PDDLStream's optimistic algorithms answer "no plan" in
milliseconds, unproven), and a variant infeasible even in the merge-safe relaxation is
still answered quickly by the optimistic ones."""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from pathlib import Path

import pytest
from pddlstream_problems import write

from ltamp_cli.pddlstream import And, PDDLProblem, from_gen_fn, solve
from ltamp_cli.pddlstream.problem import to_planning_problem
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve as plan
from ltamp_cli.planner.validate import validate_plan

ALGORITHMS = ("adaptive", "binding", "focused", "incremental")
DOMAIN = """
(define (domain visits)
  (:predicates (Conf ?q) (Seen ?q) (Stage ?s) (Next ?s ?t) (Region ?r))
  (:action go
    :parameters (?q ?s ?t)
    :precondition (and (Conf ?q) (not (Seen ?q)) (Stage ?s) (Next ?s ?t))
    :effect (and (Seen ?q) (Stage ?t) (not (Stage ?s)))))
"""
STREAMS = """
(define (stream visits)
  (:stream sample :inputs (?r) :domain (Region ?r) :outputs (?q) :certified (Conf ?q)))
"""


def configurations(region: str) -> Iterator[tuple[float]]:
    """1.0, 2.0, ... without end."""
    for i in itertools.count(1):
        yield (float(i),)


def visits_problem(folder: Path, goal: object = ("Stage", "s2")) -> PDDLProblem:
    init = [("Region", "r"), ("Stage", "s0"), ("Next", "s0", "s1"), ("Next", "s1", "s2")]
    return PDDLProblem(write(folder, "domain.pddl", DOMAIN), {},
                       write(folder, "stream.pddl", STREAMS),
                       {"sample": from_gen_fn(configurations)}, init, goal)


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_two_outputs_of_one_instance(tmp_path: Path, algorithm: str) -> None:
    solution = solve(visits_problem(tmp_path), algorithm=algorithm, max_time=30,
                     verbose=False)
    assert solution.plan is not None
    assert [action.args for action in solution.plan] == [(1.0, "s0", "s1"),
                                                         (2.0, "s1", "s2")]
    assert solution.cost == 2
    problem = to_planning_problem(visits_problem(tmp_path))
    result = plan(problem, PlannerConfig(algorithm=algorithm, max_time=30))
    report = validate_plan(problem, result)
    assert result.solved and report.valid, report.errors


@pytest.mark.parametrize("algorithm", ("adaptive", "binding", "focused"))
def test_relaxed_infeasible_variant_answers_without_the_time_limit(tmp_path: Path,
                                                                    algorithm: str) -> None:
    """max_time=inf: only a proof of infeasibility can end this solve."""
    goal = And(("Stage", "s2"), ("Seen", "r"))
    problem = to_planning_problem(visits_problem(tmp_path, goal))
    result = plan(problem, PlannerConfig(algorithm=algorithm, max_time=float("inf")))
    assert result.status == "infeasible"
    solution = solve(visits_problem(tmp_path, goal), algorithm=algorithm, verbose=False)
    assert solution.plan is None


@pytest.mark.parametrize("algorithm", ("adaptive", "binding", "focused"))
def test_deleted_stages_answer_without_the_time_limit(tmp_path: Path, algorithm: str) -> None:
    """s0 and s2 at once: reachable in the relaxation (deletes dropped), unreachable in the
    abstract task exact over known objects, so max_time=inf ends with "no plan" (a
    timeout before: the incremental fallback never runs out of samples)."""
    goal = And(("Stage", "s2"), ("Stage", "s0"))
    problem = to_planning_problem(visits_problem(tmp_path, goal))
    result = plan(problem, PlannerConfig(algorithm=algorithm, max_time=float("inf")))
    assert result.status == "infeasible"
    assert "completed_by" not in result.stats
    solution = solve(visits_problem(tmp_path, goal), algorithm=algorithm, verbose=False)
    assert solution.plan is None
