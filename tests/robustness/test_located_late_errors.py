"""Refusals found while normalising a domain name the action or axiom they come from.

A precondition of 16 ``(or ...)`` conjuncts expands to 65 536 disjuncts (over the 20 000
limit): refused in one line, but before round 6 without a position ("ltamp: error: a formula
expands to more than 20000 disjuncts"), in a domain of many actions and axioms.
"""

from __future__ import annotations

import io
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from ltamp_cli.cli.app import main

ORS = " ".join("(or (AtConf ?a) (Conf ?b))" for _ in range(16))
DOMAIN = """(define (domain wide)
  (:requirements :adl :derived-predicates)
  (:predicates (Conf ?q) (AtConf ?q) (Fine ?q))
  (:derived (Fine ?q) (and (Conf ?q) DERIVED))
  (:action move :parameters (?a ?b)
    :precondition (and (AtConf ?a) (Conf ?b) PRECONDITION)
    :effect (and (AtConf ?b) (not (AtConf ?a)))))
"""
PROBLEM = """name: wide
domain: domain
objects: {q0: null, q1: null}
init: ["(Conf q0)", "(Conf q1)", "(AtConf q0)"]
goal: (AtConf q1)
"""


def _refusal(args: list[str]) -> list[str]:
    """The CLI's stderr lines for ``args``, which must exit 2 with one line."""
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err), \
            pytest.raises(SystemExit) as done:
        main(args)
    lines = err.getvalue().strip().splitlines()
    assert done.value.code == 2 and len(lines) == 1, lines
    return lines


def _plain_domain(tmp_path: Path) -> str:
    """Write the domain without wide formulas; return a goal part of 16 ``(or ...)``."""
    (tmp_path / "domain").mkdir()
    (tmp_path / "domain" / "domain.pddl").write_text(
        DOMAIN.replace("PRECONDITION", "").replace("DERIVED", ""))
    return " ".join("(or (AtConf q0) (Conf q1))" for _ in range(16))


@pytest.mark.parametrize("where, line, what", [
    ("PRECONDITION", 5, "action 'move'"),
    ("DERIVED", 4, "derived predicate 'fine'"),
])
def test_a_formula_too_large_is_located(tmp_path: Path, where: str, line: int,
                                        what: str) -> None:
    text = DOMAIN.replace(where, ORS.replace("?a", "?q").replace("?b", "?q")
                          if where == "DERIVED" else ORS)
    text = text.replace("PRECONDITION", "").replace("DERIVED", "")
    (tmp_path / "domain").mkdir()
    domain = tmp_path / "domain" / "domain.pddl"
    domain.write_text(text)
    path = tmp_path / "problem.yaml"
    path.write_text(PROBLEM)
    lines = _refusal(["solve", str(path), "--max-time", "20", "--no-stats"])
    assert lines[0].startswith(f"ltamp: error: {domain}:{line}:3: {what}: a formula expands "
                               "to more than"), lines


def test_a_goal_too_large_is_located(tmp_path: Path) -> None:
    """The goal's refusal names the YAML line of ``goal:`` (before: no position)."""
    ors = _plain_domain(tmp_path)
    path = tmp_path / "problem.yaml"
    path.write_text(PROBLEM.replace("goal: (AtConf q1)", f'goal: "(and (AtConf q1) {ors})"'))
    lines = _refusal(["solve", str(path), "--max-time", "20", "--no-stats"])
    assert lines[0].startswith(f"ltamp: error: {path}:5:7: the goal: a formula expands to "
                               "more than"), lines


def test_a_goal_too_large_in_a_pddl_problem_names_the_file(tmp_path: Path) -> None:
    ors = _plain_domain(tmp_path)
    path = tmp_path / "problem.pddl"
    path.write_text(f"(define (problem wide) (:domain wide) (:objects q0 q1)\n"
                    f"  (:init (Conf q0) (Conf q1) (AtConf q0))\n"
                    f"  (:goal (and (AtConf q1) {ors})))\n")
    lines = _refusal(["solve", str(path), "--domain", str(tmp_path / "domain"),
                      "--max-time", "20", "--no-stats"])
    assert lines[0].startswith(f"ltamp: error: {path}:"), lines
    assert "the goal: a formula expands to more than" in lines[0], lines
