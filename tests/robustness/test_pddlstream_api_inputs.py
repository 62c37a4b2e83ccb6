"""``PDDLProblem`` fields of the wrong type are one ``InputError`` line, as every other bad
input of the drop-in API. Before the fix: ``stream_pddl=5`` raised TypeError,
``domain_pddl=None`` or ``[text, None]`` AttributeError, bytes TypeError."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).parent))

import redteam_problems as problems

from ltamp_cli.pddlstream import InputError, solve


@pytest.mark.parametrize("field, value, expected", [
    ("stream_pddl", 5, "stream_pddl"),
    ("stream_pddl", "LIST_WITH_NONE", "stream_pddl"),
    ("domain_pddl", None, "domain_pddl"),
    ("domain_pddl", b"(define (domain x))", "domain_pddl"),
])
def test_wrong_field_type_is_one_line(tmp_path: Path, field: str, value: Any,
                                      expected: str) -> None:
    problem, _ = problems.conveyor_problem(tmp_path)
    if value == "LIST_WITH_NONE":
        value = [problem.stream_pddl, None]
    with pytest.raises(InputError, match=expected) as error:
        solve(problem._replace(**{field: value}), max_time=5, verbose=False)
    assert "\n" not in str(error.value)
