"""Planner options the CLI flags and the Python API accept must be the ones the YAML
schema accepts. Before the fix ``--success-cost nan`` (and ``PlannerConfig(success_cost=
nan)``) was taken although ``planner: {success_cost: .nan}`` is refused, and a skeleton
pattern naming no action of the domain (``--skeleton 'pik a ?'``) made the problem
"infeasible" instead of an error."""

from __future__ import annotations

import io
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem

PROBLEM = Path(__file__).resolve().parents[2] / "problems" / "examples" / "kitchen_symbolic.yaml"
BAD = {
    "NaN success cost": (["--success-cost", "nan"], {"success_cost": float("nan")},
                         "success cost"),
    "unknown action in a skeleton": (["--skeleton", "pik mug ? ? ?"],
                                     {"skeleton": ("pik mug ? ? ?",)}, "no such action"),
    "wrong arity in a skeleton": (["--skeleton", "pick mug"], {"skeleton": ("pick mug",)},
                                  "argument(s)"),
}


@pytest.mark.parametrize("label", sorted(BAD))
def test_bad_option_is_one_line(label: str) -> None:
    flags, fields, expected = BAD[label]
    with pytest.raises(InputError, match=expected.replace("(", r"\(").replace(")", r"\)")):
        solve(load_problem(PROBLEM), PlannerConfig(max_time=5, **fields))
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["solve", str(PROBLEM), "--max-time", "5", "--no-stats", *flags])
    lines = err.getvalue().strip().splitlines()
    assert done.value.code == 2 and len(lines) == 1 and expected in lines[0], lines


def test_good_skeleton_still_solves() -> None:
    result = solve(load_problem(PROBLEM),
                   PlannerConfig(max_time=30, skeleton=("...", "pick ? ? ? ?", "...")))
    assert result.solved


def test_flag_that_is_no_boolean_is_refused() -> None:
    """unit_costs="no" was taken as true (a non-empty string)."""
    with pytest.raises(InputError, match="unit costs: expected True or False"):
        solve(load_problem(PROBLEM), PlannerConfig(max_time=5, unit_costs="no"))  # type: ignore[arg-type]
