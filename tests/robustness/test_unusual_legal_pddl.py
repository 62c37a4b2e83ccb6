"""``ltamp solve`` on YAML problems wrapping unusual but legal PDDL: it solves, or refuses in
one line with ``file:line:column`` naming the construct.

Solved here (checked: the plan moves the block where the goal wants it): comments after
every token, requirements ltamp does not list (or none), upper and mixed case, ``=`` in
preconditions and goals, an empty ``:init``, objects named ``and``/``not``/``either``/
``object``/``forall``/``define``, constants, typed object lists across lines, tabs and CRLF.
Refused: ``either`` types and numeric conditions (``(>= (fuel ?b) 1)``); before the fix a
numeric condition was read as a predicate named ``>=`` and refused as "expected an argument
of (>= ...), found a list", which named no construct.
"""

from __future__ import annotations

import io
import re
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from ltamp_cli.cli.app import main

DOMAIN = """(define (domain mini)
  (:requirements :strips :typing :equality)
  (:types block place - object)
  (:predicates (at ?b - block ?p - place) (free ?p - place))
  (:action move
    :parameters (?b - block ?from - place ?to - place)
    :precondition (and (at ?b ?from) (free ?to) (not (= ?from ?to)))
    :effect (and (at ?b ?to) (free ?from) (not (at ?b ?from)) (not (free ?to)))))
"""
PROBLEM = """(define (problem p) (:domain mini)
  (:objects b1 - block p1 p2 p3 - place)
  (:init (at b1 p1) (free p2) (free p3))
  (:goal (at b1 p3)))
"""


def _comments(text: str) -> str:
    return "; a comment first\n" + text.replace("(", "( ; (comment\n").replace(")", " ; )\n)")


def _rename(text: str, names: dict[str, str]) -> str:
    return re.sub(r"\b(b1|p1|p2|p3)\b", lambda m: names.get(m.group(1), m.group(1)), text)


KEYWORDS = {"b1": "and", "p1": "not", "p2": "either", "p3": "object"}
KEYWORDS2 = {"b1": "forall", "p1": "exists", "p2": "when", "p3": "define"}
FUEL = (DOMAIN.replace(":equality", ":equality :numeric-fluents")
        .replace("(:action", "(:functions (fuel ?b - block))\n  (:action")
        .replace("(not (= ?from ?to)))", "(not (= ?from ?to)) (>= (fuel ?b) 1))"))
EITHER = (DOMAIN.replace("(:types block place - object)", "(:types block place table - object)")
          .replace("?to - place)\n", "?to - (either place table))\n"))

SOLVED = {
    "comments": (_comments(DOMAIN), _comments(PROBLEM), "move b1 p1 p3"),
    "unlisted requirements": (DOMAIN.replace(
        ":equality)", ":equality :durative-actions :numeric-fluents :fluents :preferences "
        ":timed-initial-literals :object-fluents :some-future-requirement)"), PROBLEM,
        "move b1 p1 p3"),
    "no requirements": (DOMAIN.replace("(:requirements :strips :typing :equality)", ""),
                        PROBLEM, "move b1 p1 p3"),
    "upper case": (DOMAIN.upper(), PROBLEM.upper(), "move b1 p1 p3"),
    "mixed case": (DOMAIN.replace("define", "DEFINE").replace("(at ?b ?from)", "(AT ?B ?from)")
                   .replace(":effect", ":Effect"),
                   PROBLEM.replace(":init", ":INIT").replace("(at b1 p3)", "(At B1 P3)"),
                   "move b1 p1 p3"),
    "= in goal": (DOMAIN, PROBLEM.replace("(:goal (at b1 p3))",
                                          "(:goal (and (at b1 p3) (not (= p1 p2))))"),
                  "move b1 p1 p3"),
    "empty init": (DOMAIN, PROBLEM.replace("(:init (at b1 p1) (free p2) (free p3))", "(:init)")
                   .replace("(:goal (at b1 p3))", "(:goal (not (at b1 p3)))"), None),
    "keyword objects": (DOMAIN, _rename(PROBLEM, KEYWORDS), "move and not object"),
    "keyword objects 2": (DOMAIN, _rename(PROBLEM, KEYWORDS2), "move forall exists define"),
    "keyword parameters": (DOMAIN.replace("?from", "?and").replace("?to", "?not"), PROBLEM,
                           "move b1 p1 p3"),
    "constants": (DOMAIN.replace("(:predicates", "(:constants p3 - place)\n  (:predicates"),
                  PROBLEM.replace("p1 p2 p3 - place", "p1 p2 - place"), "move b1 p1 p3"),
    "objects across lines": (DOMAIN, PROBLEM.replace("b1 - block p1 p2 p3 - place",
                                                     "b1\n - \n block\n p1\n p2 p3 -\nplace"),
                             "move b1 p1 p3"),
    "tabs and crlf": (DOMAIN.replace(" ", "\t").replace("\n", "\r\n"),
                      PROBLEM.replace("\n", "\r\n"), "move b1 p1 p3"),
}

REFUSED = {
    "either type": (EITHER, PROBLEM, "domain.pddl:6:", "'either' types are not supported"),
    "numeric condition": (FUEL, PROBLEM.replace("(free p3))", "(free p3) (= (fuel b1) 5))"),
                          "domain.pddl:8:", "numeric condition (>= ...)"),
    "numeric = condition": (FUEL.replace("(>= (fuel ?b) 1)", "(= (fuel ?b) 5)"),
                            PROBLEM.replace("(free p3))", "(free p3) (= (fuel b1) 5))"),
                            "domain.pddl:8:", "numeric condition (= ...)"),
    "numeric goal": (FUEL.replace(" (>= (fuel ?b) 1)", ""),
                     PROBLEM.replace("(:goal (at b1 p3))", "(:goal (< (fuel b1) 9))"),
                     "problem.pddl:4:", "numeric condition (< ...) in the goal"),
}


def _write(tmp_path: Path, domain: str, problem: str) -> Path:
    (tmp_path / "domain").mkdir()
    (tmp_path / "domain" / "domain.pddl").write_text(domain, newline="")
    (tmp_path / "problem.pddl").write_text(problem, newline="")
    path = tmp_path / "problem.yaml"
    path.write_text("name: unusual\ndomain: domain\npddl_problem: problem.pddl\n")
    return path


def _solve(path: Path) -> tuple[int, str, list[str]]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["solve", str(path), "--no-stats", "--max-time", "60"])
    return int(done.value.code or 0), out.getvalue(), err.getvalue().strip().splitlines()


@pytest.mark.parametrize("case", sorted(SOLVED))
def test_unusual_legal_pddl_solves(tmp_path: Path, case: str) -> None:
    domain, problem, action = SOLVED[case]
    code, out, err = _solve(_write(tmp_path, domain, problem))
    assert code == 0, err
    steps = [line.split(". ", 1)[1].lower() for line in out.splitlines()
             if re.match(r"\d+\. ", line)]
    assert steps == ([action] if action else []), out


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_unsupported_legal_pddl_is_one_line_naming_the_construct(tmp_path: Path,
                                                                 case: str) -> None:
    domain, problem, where, what = REFUSED[case]
    code, _out, err = _solve(_write(tmp_path, domain, problem))
    assert code == 2 and len(err) == 1, err
    assert re.search(re.escape(where) + r"\d+: ", err[0]) and what in err[0], err
