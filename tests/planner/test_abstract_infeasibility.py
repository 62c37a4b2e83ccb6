"""A sound, fast "infeasible" when deletes or negation make a problem unsolvable although
generators never end (issue #19, D): the abstract task of
:mod:`ltamp_cli.planner.algorithms.abstract_task` keeps deletes and negation exact over known
objects. The corpus (``bench/infeasible_corpus.py``) pairs each infeasible problem with a
solvable look-alike; four look-alikes are solvable only because the abstract task relaxes
what concerns stand-ins (a negated fact of an output, an inequality between two outputs of
one instance, a conditional effect whose condition mentions an output, a derived fact
derived through an output): checking those exactly answers them "infeasible" (measured by
mutating the module), so these tests fail if the relaxation of any of them is lost."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from bench.infeasible_corpus import BY_NAME, CORPUS, LOOK_DOMAIN, VISITS_STREAMS, write_problem
from ltamp_cli.planner.algorithms.abstract_task import search_abstract_task
from ltamp_cli.planner.algorithms.common import PlannerConfig, initial_state
from ltamp_cli.planner.algorithms.multiplicity import (
    ABSTRACT_PROOF,
    RELAXATION_PROOF,
    relaxed_closure,
)
from ltamp_cli.planner.api import MULTIPLICITY_NOTE, solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

OPTIMISTIC = ("adaptive", "binding", "focused")
ALGORITHMS = (*OPTIMISTIC, "incremental")
INFEASIBLE = [p.name for p in CORPUS if p.expected == "infeasible"]
SOLVABLE = [p.name for p in CORPUS if p.expected == "solved"]
# Solvable only through a relaxation the abstract task makes for stand-ins.
GUARDS = ("visits_four_outputs", "looks_three_three_tokens", "visits_when_fresh",
          "visits_busy_derived")


@pytest.mark.parametrize("algorithm", OPTIMISTIC)
@pytest.mark.parametrize("name", INFEASIBLE)
def test_infeasible_corpus_is_proven(tmp_path: Path, name: str, algorithm: str) -> None:
    problem = load_problem(write_problem(BY_NAME[name], tmp_path))
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=30))
    assert result.status == "infeasible", result.stats.get("completed_by")
    assert result.stats["infeasibility_check"] in (ABSTRACT_PROOF, RELAXATION_PROOF)
    assert "completed_by" not in result.stats  # no fallback ran


@pytest.mark.parametrize("algorithm", ALGORITHMS)
@pytest.mark.parametrize("name", SOLVABLE)
def test_solvable_look_alikes_are_solved(tmp_path: Path, name: str, algorithm: str) -> None:
    problem = load_problem(write_problem(BY_NAME[name], tmp_path))
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=30))
    assert result.status == "solved", result.stats.get("infeasibility_check")
    report = validate_plan(problem, result)
    assert report.valid, report.errors
    if name in GUARDS and algorithm != "incremental":
        assert result.stats["infeasibility_check"] == "goal reachable in the abstract task"
        assert MULTIPLICITY_NOTE in result.stats["completed_by"]


@pytest.mark.parametrize("name", GUARDS)
def test_guards_are_reachable_in_the_abstract_task(tmp_path: Path, name: str) -> None:
    """Directly on the initial state: the goal is reachable (never proven unreachable)."""
    state = initial_state(load_problem(write_problem(BY_NAME[name], tmp_path)),
                          PlannerConfig())
    assert search_abstract_task(relaxed_closure(state), float("inf")).reachable is True


@pytest.mark.parametrize("name", ["visits_blocked_samples", "looks_three_two_tokens"])
def test_unprovable_infeasibility_is_a_timeout_naming_why(tmp_path: Path, name: str) -> None:
    """Infeasible only through facts of values not sampled yet (every sample blocked; three
    distinct outputs, two tokens): the abstract task reaches the goal, the fallback runs
    until max_time, and the stats say so."""
    problem = load_problem(write_problem(BY_NAME[name], tmp_path))
    result = solve(problem, PlannerConfig(algorithm="binding", max_time=0.5))
    assert result.status == "timeout"
    assert result.stats["infeasibility_check"] == "goal reachable in the abstract task"
    assert result.stats["completed_by"].startswith("incremental (" + MULTIPLICITY_NOTE)


def test_unbounded_fallback_warns(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """max_time=inf and an infeasibility the abstract task cannot prove: the solve says
    (logger ``ltamp``) that the incremental algorithm goes on without a limit; here the
    generator ends after three values, so it ends, "infeasible", once exhausted."""
    folder = tmp_path / "dom"
    folder.mkdir()
    (folder / "domain.pddl").write_text(LOOK_DOMAIN)
    (folder / "stream.pddl").write_text(VISITS_STREAMS)
    (tmp_path / "bindings.py").write_text(
        "def make_streams(world, rng):\n"
        "    def sample(r):\n"
        "        yield from ((1.0,), (2.0,), (3.0,))\n"
        "    return {'sample': sample}\n")
    path = tmp_path / "problem.yaml"
    path.write_text(
        "domain: dom\nbindings: bindings.py\nworld: {}\nobjects: {r: null, t0: null, "
        "t1: null}\ninit: ['(Region r)', '(Token t0)', '(Token t1)']\n"
        "goal: (exists (?a ?b ?c) (and (Seen ?a) (Seen ?b) (Seen ?c) (not (= ?a ?b)) "
        "(not (= ?a ?c)) (not (= ?b ?c))))\n")
    with caplog.at_level(logging.WARNING, logger="ltamp"):
        result = solve(load_problem(path),
                       PlannerConfig(algorithm="adaptive", max_time=float("inf")))
    assert result.status == "infeasible"
    assert "incremental" in result.stats["completed_by"]
    assert any("without a time limit" in r.getMessage() for r in caplog.records)
