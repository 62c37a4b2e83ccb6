"""A test stream's fact in a conditional effect's condition must be certified before a plan
that needs the effect is returned.

``(when (Hits ?b ?v) (Broken ?v))`` with ``Hits`` certified by a test: the optimistic
algorithms (focused, binding, adaptive) ground the effect with the test's optimistic fact,
drop the (static) condition, and never asked the test. For the goal ``(Broken v1)`` they
returned ``move(0.0, 0.0)``: moving onto the start, nowhere near the vase; incremental moved
to 5.0, next to it. The fact is now part of the plan's preimage, as a precondition's is.
"""

from __future__ import annotations

import io
import json
import sys
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

import pytest

from ltamp_cli.cli.app import main
from ltamp_cli.pddlstream import And, Exists, Not, PDDLProblem, from_gen_fn, from_test, solve
from ltamp_cli.pddlstream.problem import to_planning_problem
from ltamp_cli.planner.algorithms.common import ALGORITHMS, PlannerConfig
from ltamp_cli.planner.api import solve as plan
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

DOMAIN = """(define (domain knock)
  (:requirements :strips :conditional-effects :negative-preconditions)
  (:predicates (Conf ?q) (AtConf ?q) (Vase ?v) (Hits ?q ?v) (Broken ?v))
  (:action move :parameters (?a ?b)
    :precondition (and (AtConf ?a) (Conf ?b))
    :effect (and (AtConf ?b) (not (AtConf ?a))
                 (forall (?v) (when (and (Vase ?v) (Hits ?b ?v)) (Broken ?v))))))
"""
STREAM = """(define (stream knock)
  (:stream sample :inputs () :domain () :outputs (?q) :certified (Conf ?q))
  (:stream hits :inputs (?q ?v) :domain (and (Conf ?q) (Vase ?v)) :certified (Hits ?q ?v)))
"""
VASE_X = 5.0


def _samples() -> Any:
    for x in (1.0, VASE_X, 9.0):
        yield (x,)


def _hits(q: float, v: Any) -> bool:
    return abs(float(q) - VASE_X) < 0.5


GOALS = {
    "broken": ("Broken", "v1"),
    "broken, then away": And(("Broken", "v1"), Exists(["?q"], ("AtConf", "?q")),
                             Not(("AtConf", VASE_X))),
}


def _problem(goal: Any) -> PDDLProblem:
    init = [("Conf", 0.0), ("AtConf", 0.0), ("Vase", "v1")]
    stream_map = {"sample": from_gen_fn(_samples), "hits": from_test(_hits)}
    return PDDLProblem(DOMAIN, {}, STREAM, stream_map, init, goal)


def _knocks_the_vase(steps: list[tuple[str, tuple[Any, ...]]]) -> bool:
    return any(name == "move" and abs(float(args[1]) - VASE_X) < 0.5 for name, args in steps)


@pytest.mark.parametrize("goal", sorted(GOALS))
@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_the_api_certifies_a_conditional_effects_test(algorithm: str, goal: str) -> None:
    problem = _problem(GOALS[goal])
    solution = solve(problem, algorithm=algorithm, max_time=20, verbose=False)
    assert solution.plan is not None, algorithm
    steps = [(action.name, tuple(action.args)) for action in solution.plan]
    assert _knocks_the_vase(steps), steps  # before: [('move', (0.0, 0.0))]
    planning = to_planning_problem(problem)
    result = plan(planning, PlannerConfig(algorithm=algorithm, max_time=20))
    assert result.solved and validate_plan(planning, result).valid
    # the certificate names the test's fact the plan relies on
    assert any(f[0].lower() == "hits" and abs(float(f[1]) - VASE_X) < 0.5
               for f in solution.certificate.preimage_facts), solution.certificate


BINDINGS = f"""
def make_streams(world, rng):
    def sample():
        for x in (1.0, {VASE_X}, 9.0):
            yield (x,)
    return {{"sample": sample, "hits": lambda q, v: abs(float(q) - float(v)) < 0.5}}
"""
YAML = f"""name: knock
domain: domain
bindings: streams.py
objects: {{q0: 0.0, v1: {VASE_X}}}
init: ["(Conf q0)", "(AtConf q0)", "(Vase v1)"]
goal: (Broken v1)
"""


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_ltamp_solve_certifies_a_conditional_effects_test(tmp_path: Path,
                                                          algorithm: str) -> None:
    (tmp_path / "domain").mkdir()
    (tmp_path / "domain" / "domain.pddl").write_text(DOMAIN)
    (tmp_path / "domain" / "stream.pddl").write_text(STREAM)
    (tmp_path / "streams.py").write_text(BINDINGS)
    path = tmp_path / "problem.yaml"
    path.write_text(YAML)
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["solve", str(path), "--algorithm", algorithm, "--max-time", "20", "--seed", "0",
              "--no-stats", "--json"])
    assert done.value.code in (0, None), err.getvalue()[-500:]
    assert json.loads(out.getvalue())["status"] == "solved"
    loaded = load_problem(path)
    result = plan(loaded, PlannerConfig(algorithm=algorithm, max_time=20, seed=0))
    assert result.solved and result.plan is not None
    report = validate_plan(loaded, result)
    assert report.valid, report  # before: move(q0, q0), the vase not broken
    sys.modules.pop("streams", None)


NEGATED_DOMAIN = """(define (domain spare)
  (:requirements :strips :conditional-effects :negative-preconditions)
  (:predicates (Conf ?q) (Sampled ?q) (AtConf ?q) (Vase ?v) (Hits ?q ?v) (Intact ?v))
  (:action move :parameters (?a ?b)
    :precondition (and (AtConf ?a) (Sampled ?b))
    :effect (and (AtConf ?b) (not (AtConf ?a))
                 (forall (?v) (when (and (Vase ?v) (not (Hits ?b ?v))) (Intact ?v))))))
"""
NEGATED_STREAM = """(define (stream spare)
  (:stream sample :inputs () :domain () :outputs (?q) :certified (and (Conf ?q) (Sampled ?q)))
  (:stream hits :inputs (?q ?v) :domain (and (Conf ?q) (Vase ?v)) :certified (Hits ?q ?v)))
"""


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_a_negated_test_in_a_when_is_certified(algorithm: str) -> None:
    """``(when (not (Hits ?b ?v)) (Intact ?v))`` is compiled to the negated test's fact
    ``(~hits ?b ?v)``, static in the condition: before, focused and binding moved onto the
    vase (5.0) and adaptive to 9.0 without calling the test; now every plan's move target
    was tested clear of the vase."""
    calls: list[float] = []

    def samples() -> Any:
        yield from ((x,) for x in (VASE_X, 1.0, 9.0))

    def hits(q: float, v: Any) -> bool:
        calls.append(q)
        return _hits(q, v)

    problem = PDDLProblem(NEGATED_DOMAIN, {}, NEGATED_STREAM,
                          {"sample": from_gen_fn(samples), "hits": from_test(hits)},
                          [("Conf", 0.0), ("AtConf", 0.0), ("Vase", "v1")], ("Intact", "v1"))
    solution = solve(problem, algorithm=algorithm, max_time=20, verbose=False)
    assert solution.plan is not None, algorithm
    (step,) = solution.plan
    target = float(step.args[1])
    assert not _hits(target, "v1") and target in calls, (target, calls)
    planning = to_planning_problem(problem)
    result = plan(planning, PlannerConfig(algorithm=algorithm, max_time=20))
    assert result.solved and validate_plan(planning, result).valid


def test_a_cost_increase_inside_when_is_located(tmp_path: Path) -> None:
    """Refused before, but at search time and without a position ("ltamp: error: a cost
    increase inside 'when' is not supported"); now at its file:line:col when the domain is
    read, exit 2."""
    (tmp_path / "domain").mkdir()
    costly = DOMAIN.replace("(Broken ?v))))))",
                            "(Broken ?v))) (when (Conf ?a) (increase (total-cost) 2)))))")
    assert costly != DOMAIN
    (tmp_path / "domain" / "domain.pddl").write_text(costly)
    (tmp_path / "domain" / "stream.pddl").write_text(STREAM)
    (tmp_path / "streams.py").write_text(BINDINGS)
    path = tmp_path / "problem.yaml"
    path.write_text(YAML)
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err), \
            pytest.raises(SystemExit) as done:
        main(["solve", str(path), "--max-time", "5", "--no-stats"])
    lines = err.getvalue().strip().splitlines()
    assert done.value.code == 2 and len(lines) == 1, lines
    domain_file = tmp_path / "domain" / "domain.pddl"
    assert lines[0].startswith(f"ltamp: error: {domain_file}:7:"), lines
    assert "cost increase inside 'when'" in lines[0]
