"""ltamp_cli.pddlstream.helpers: the general helpers served as ``pddlstream.utils`` (and
``.language.temporal``, ``.algorithms.downward``) behave as PDDLStream scripts expect."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.pddlstream import Action, Minimize
from ltamp_cli.pddlstream import helpers as h


def test_sequence_helpers() -> None:
    assert list(h.safe_zip([1, 2], "ab")) == [(1, "a"), (2, "b")]
    with pytest.raises(ValueError, match="lengths differ"):
        h.safe_zip([1, 2], [1])
    assert list(h.flatten([[1, 2], (3,), []])) == [1, 2, 3]
    assert h.find_unique(lambda x: x > 2, [1, 3]) == 3
    with pytest.raises(RuntimeError, match="2 items"):
        h.find_unique(lambda x: x > 0, [1, 3])
    assert h.find(lambda x: x > 5, [1, 3]) is None
    assert list(h.irange(3)) == [0, 1, 2] and list(h.irange(0.0, 1.0, 0.25)) == [
        0.0, 0.25, 0.5, 0.75]
    assert h.safe_apply_mapping(("a", "b"), {"a": 1, "b": 2}) == (1, 2)
    assert h.apply_mapping(("a", "c"), {"a": 1}) == (1, "c")
    incoming, outgoing = h.neighbors_from_orders([("a", "b"), ("a", "c")])
    assert incoming["b"] == {"a"} and outgoing["a"] == {"b", "c"}
    assert h.implies(False, False) and not h.implies(True, False)
    assert h.str_eq("AtPose", "atpose") and not h.str_eq("AtPose", "atpose", ignore_case=False)
    assert h.value_or_id((1, 2)) == (1, 2)
    array = np.zeros(2)
    assert h.value_or_id(array) == id(array)
    assert not h.is_hashable(([1],)) and h.is_hashable((1,))
    assert h.negate_test(lambda x: x > 1)(0) is True
    assert next(h.inf_generator()) == 0


def test_str_from_object_is_sorted_and_rounded() -> None:
    text = h.str_from_object({"b": [1.23456, -0.0001], "a": {3, 1}}, ndigits=2)
    assert text == "{a: {1, 3}, b: [1.23, 0.00]}"
    assert h.sorted_str_from_list(["b", "a"]) == "[a, b]"


def test_temporal_helpers_retime_a_sequential_plan() -> None:
    plan = [Action("move", ("q0", "q1")), Action("pick", ("b",))]
    timed = h.retime_plan(plan, duration=2.0)
    assert timed is not None
    assert [(a.name, a.start, a.duration) for a in timed] == [("move", 0.0, 2.0),
                                                              ("pick", 2.0, 2.0)]
    assert h.compute_duration(timed) == 4.0 and h.get_end(timed[1]) == 4.0
    assert h.retime_plan(None) is None and h.compute_duration([]) == 0.0


def test_constants_and_downward_helpers() -> None:
    terms = [("Slot", "?a"), Minimize(("Distance", "?a", "?b"))]
    assert h.get_constraints(terms) == [("Slot", "?a")]
    assert h.get_parameter_name("?a") == "a" and h.get_parameter_name("a") == "a"
    h.set_cost_scale(1000)
    with pytest.raises(ValueError, match="positive"):
        h.set_cost_scale(0)
    assert h.MAX_FD_COST == 1e8 and math.isinf(h.INF)


def test_files_and_profiler(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    script = tmp_path / "run.py"
    (tmp_path / "domain.pddl").write_text("(define (domain d))")
    text = h.read_pddl(str(script), "domain.pddl")
    assert text == "(define (domain d))" and text.path == str(tmp_path / "domain.pddl")
    h.ensure_dir(str(tmp_path / "out" / "plan.txt"))
    assert (tmp_path / "out").is_dir()
    h.safe_rm_dir(str(tmp_path / "out"))
    assert not (tmp_path / "out").exists()
    with h.Profiler(field="cumtime", num=3):
        sum(range(1000))
    assert "function calls" in capsys.readouterr().out
    with pytest.raises(ValueError, match="field"):
        h.Profiler(field="calls")
