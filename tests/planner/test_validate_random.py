"""The validator against a hand-written blocksworld simulator on random action sequences."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from ltamp_cli.planner.problem import PlanningProblem, load_problem
from ltamp_cli.planner.result import Certificate, PlanResult, PlanStep
from ltamp_cli.planner.validate import validate_plan

REPO = Path(__file__).resolve().parents[2]
BLOCKS = ("a", "b", "c")
GROUND = [("pick-up", (x,)) for x in BLOCKS] + [("put-down", (x,)) for x in BLOCKS] + [
    (name, (x, y)) for name in ("stack", "unstack")
    for x, y in itertools.permutations(BLOCKS, 2)]


@pytest.fixture(scope="module")
def tower(tmp_path_factory: pytest.TempPathFactory) -> PlanningProblem:
    folder = tmp_path_factory.mktemp("bw")
    path = folder / "p.pddl"
    path.write_text("(define (problem p) (:domain blocksworld) (:objects a b c - block)\n"
                    " (:init (on a b) (ontable b) (ontable c) (clear a) (clear c) (handempty))\n"
                    " (:goal (and (handempty) (clear b))))\n")
    return load_problem(path, REPO / "domains" / "blocksworld")


def simulate(steps: list[tuple[str, tuple[str, ...]]]) -> tuple[int | None, bool]:
    """(first inapplicable step number or None, goal reached) by blocksworld's rules."""
    on = {"a": "b"}
    table = {"b", "c"}
    holding: str | None = None

    def clear(x: str) -> bool:
        return x not in on.values() and holding != x

    for number, (name, args) in enumerate(steps, start=1):
        x = args[0]
        if name == "pick-up" and x in table and clear(x) and holding is None:
            table.remove(x)
            holding = x
        elif name == "put-down" and holding == x:
            table.add(x)
            holding = None
        elif name == "stack" and holding == x and clear(args[1]) and x != args[1]:
            on[x] = args[1]
            holding = None
        elif name == "unstack" and on.get(x) == args[1] and clear(x) and holding is None:
            del on[x]
            holding = x
        else:
            return number, False
    return None, holding is None and clear("b")


@settings(max_examples=80, deadline=None)
@given(st.lists(st.sampled_from(GROUND), max_size=7))
@example([("unstack", ("a", "b")), ("put-down", ("a",))])  # a valid plan
@example([("unstack", ("a", "b")), ("stack", ("a", "c")), ("unstack", ("a", "b"))])
def test_validator_agrees_with_simulator(tower: PlanningProblem,
                                         steps: list[tuple[str, tuple[str, ...]]]) -> None:
    plan = [PlanStep(name, args, args, 1.0) for name, args in steps]
    result = PlanResult("solved", plan, float(len(plan)), 0.0, {}, Certificate())
    report = validate_plan(tower, result)
    failing, goal = simulate(steps)
    assert report.valid == (failing is None and goal), report.errors
    if failing is not None:
        assert report.errors[0].startswith(f"step {failing} "), report.errors
    elif not goal:
        assert report.errors[-1].startswith("goal: does not hold")
    else:
        assert report.cost == len(plan)
