"""Two distinct outputs of one stream instance (round 7's "left" item): the optimistic
algorithms give an instance one placeholder, so a plan that needs two different outputs of
it has no optimistic counterpart. Their "infeasible" must then not be the answer: it is
proven only when the goal is unreachable in the merge-safe relaxation
(:mod:`ltamp_cli.planner.algorithms.multiplicity`), else the incremental algorithm goes on."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import pytest
from conftest import ALGORITHMS, MakeProblem
from test_cli import ltamp

from ltamp_cli.planner.algorithms.common import PlannerConfig, initial_state
from ltamp_cli.planner.algorithms.multiplicity import ABSTRACT_PROOF, relaxed_goal_reachable
from ltamp_cli.planner.api import MULTIPLICITY_NOTE, solve
from ltamp_cli.planner.problem import PlanningProblem, load_problem
from ltamp_cli.planner.validate import validate_plan

# ``go`` visits a configuration once (not (Seen ?q)); each visit advances the stage.
VISITS_DOMAIN = """
(define (domain visits)
  (:predicates (Conf ?q) (Seen ?q) (Stage ?s) (Next ?s ?t) (Region ?r))
  (:action go
    :parameters (?q ?s ?t)
    :precondition (and (Conf ?q) (not (Seen ?q)) (Stage ?s) (Next ?s ?t))
    :effect (and (Seen ?q) (Stage ?t) (not (Stage ?s)))))
"""
VISITS_STREAMS = """
(define (stream visits)
  (:stream sample
    :inputs (?r)
    :domain (Region ?r)
    :outputs (?q)
    :certified (Conf ?q)))
"""
# One instance, sample(r), yields 1.0, 2.0, ... (world["count"] values; null: no end).
VISITS_BINDINGS = """
import itertools

def make_streams(world, rng):
    def sample(r):
        for i in itertools.count(1):
            if world["count"] is not None and i > world["count"]:
                return
            yield (float(i),)
    return {"sample": sample}
"""


def visits_yaml(stages: int, count: int | None = None, goal: str = "") -> str:
    """A problem whose goal is the last of ``stages`` + 1 stages (one visit per step)."""
    names = [f"s{i}" for i in range(stages + 1)]
    init = ['"(Region r)"', f'"(Stage {names[0]})"',
            *(f'"(Next {a} {b})"' for a, b in itertools.pairwise(names))]
    objects = ", ".join(f"{n}: null" for n in ["r", *names])
    return (f"domain: dom\nbindings: bindings.py\n"
            f"world: {{count: {'null' if count is None else count}}}\n"
            f"objects: {{{objects}}}\ninit: [{', '.join(init)}]\n"
            f"goal: {goal or f'(Stage {names[-1]})'}\n")


def visits(make_problem: MakeProblem, stages: int, count: int | None = None,
           goal: str = "") -> Path:
    return make_problem(VISITS_DOMAIN, visits_yaml(stages, count, goal), VISITS_STREAMS,
                        VISITS_BINDINGS)


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_two_outputs_of_one_instance_are_planned(make_problem: MakeProblem,
                                                 algorithm: str) -> None:
    problem = load_problem(visits(make_problem, stages=2))
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=30))
    assert result.status == "solved", result.diagnostics
    assert [step.values for step in result.plan] == [(1.0, "s0", "s1"), (2.0, "s1", "s2")]
    report = validate_plan(problem, result)
    assert report.valid, report.errors
    if algorithm != "incremental":
        assert MULTIPLICITY_NOTE in result.stats["completed_by"]


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_cli_plans_two_outputs_of_one_instance(make_problem: MakeProblem,
                                               algorithm: str) -> None:
    run = ltamp(visits(make_problem, stages=2), "--json", "--algorithm", algorithm,
                "--max-time", "30")
    assert run.returncode == 0, (run.stdout, run.stderr)
    data = json.loads(run.stdout)
    assert data["status"] == "solved"
    assert [step["args"][0] for step in data["plan"]] == [1.0, 2.0]


@pytest.mark.parametrize("algorithm", ("adaptive", "binding", "focused"))
def test_relaxation_still_proves_infeasibility(make_problem: MakeProblem,
                                               algorithm: str) -> None:
    """r is no configuration and no stream makes it one: unreachable even in the
    relaxation, so "infeasible" stays the answer although sample(r) never runs out (the
    incremental algorithm, which could only run out of time, is not called)."""
    problem = load_problem(visits(make_problem, stages=2,
                                  goal="(and (Stage s2) (Seen r))"))
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=60))
    assert result.status == "infeasible"
    assert "completed_by" not in result.stats


@pytest.mark.parametrize("algorithm", ("adaptive", "focused"))
def test_too_few_outputs_is_infeasible_once_exhausted(make_problem: MakeProblem,
                                                      algorithm: str) -> None:
    """Three visits, two configurations: proven by calling sample(r) until it ends."""
    problem = load_problem(visits(make_problem, stages=3, count=2))
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=30))
    assert result.status == "infeasible"
    assert MULTIPLICITY_NOTE in result.stats["completed_by"]


def test_deleted_stages_are_proven_infeasible(make_problem: MakeProblem) -> None:
    """Both s0 and s2 hold only in the relaxation (stages are deleted): the abstract task,
    exact over known objects, proves it although sample(r) never ends (this was a timeout
    before it)."""
    problem = load_problem(visits(make_problem, stages=2, goal="(and (Stage s2) (Stage s0))"))
    result = solve(problem, PlannerConfig(algorithm="binding", max_time=30))
    assert result.status == "infeasible"
    assert result.plan is None
    assert result.stats["infeasibility_check"] == ABSTRACT_PROOF
    assert "completed_by" not in result.stats


def relaxed(problem: PlanningProblem) -> bool:
    return relaxed_goal_reachable(initial_state(problem, PlannerConfig()))


def test_relaxation_follows_streams_chains_and_drops_negation(make_problem: MakeProblem
                                                               ) -> None:
    # Negation and deletes are dropped: reachable.
    assert relaxed(load_problem(visits(make_problem, stages=2,
                                       goal="(and (Stage s2) (Stage s0))")))
    # Nothing makes r a configuration.
    assert not relaxed(load_problem(visits(make_problem, stages=2,
                                           goal="(and (Stage s2) (Seen r))")))
    # The goal's stage is not linked to the others.
    assert not relaxed(load_problem(make_problem(
        VISITS_DOMAIN, visits_yaml(2).replace('"(Next s1 s2)"', '"(Next s2 s1)"'),
        VISITS_STREAMS, VISITS_BINDINGS)))


CHAIN_STREAMS = """
(define (stream visits)
  (:stream sample
    :inputs (?r)
    :domain (Region ?r)
    :outputs (?q)
    :certified (Region ?q))
  (:stream conf
    :inputs (?r)
    :domain (Region ?r)
    :outputs (?q)
    :certified (and (Conf ?q) (Region ?q))))
"""

CHAIN_BINDINGS = """
def make_streams(world, rng):
    def shifted(r):
        yield (f"{r}+",)
    return {"sample": shifted, "conf": shifted}
"""


def test_relaxation_reaches_through_abstract_inputs(make_problem: MakeProblem) -> None:
    """Outputs of instances over abstract inputs (sample(sample(r))) are abstract too: the
    closure stays finite while covering every chain of calls."""
    problem = load_problem(make_problem(
        VISITS_DOMAIN, visits_yaml(3, goal="(and (Stage s3) (Seen s1))"), CHAIN_STREAMS,
        CHAIN_BINDINGS))
    assert not relaxed(problem)  # s1 is no configuration
    problem = load_problem(make_problem(
        VISITS_DOMAIN, visits_yaml(3), CHAIN_STREAMS,
        CHAIN_BINDINGS))
    assert relaxed(problem)


# No negated precondition: the goal asks for two different seen configurations.
MARK_DOMAIN = """
(define (domain marks)
  (:predicates (Conf ?q) (Seen ?q) (Region ?r))
  (:action look :parameters (?q) :precondition (Conf ?q) :effect (Seen ?q)))
"""


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_goal_inequality_between_outputs_of_one_instance(make_problem: MakeProblem,
                                                         algorithm: str) -> None:
    problem = load_problem(make_problem(
        MARK_DOMAIN,
        "domain: dom\nbindings: bindings.py\nworld: {count: null}\nobjects: {r: null}\n"
        'init: ["(Region r)"]\n'
        "goal: (exists (?a ?b) (and (Seen ?a) (Seen ?b) (not (= ?a ?b))))\n",
        VISITS_STREAMS, VISITS_BINDINGS))
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=30))
    assert result.status == "solved", result.diagnostics
    assert sorted(step.values for step in result.plan) == [(1.0,), (2.0,)]
    assert validate_plan(problem, result).valid
