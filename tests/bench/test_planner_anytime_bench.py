"""bench/planner_anytime.py on a small case: its rows count ``make_streams`` calls and rounds,
and its table and JSON are written."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench import planner_anytime


def test_anytime_bench_counts_make_streams_and_rounds(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "anytime.json"
    planner_anytime.main(["--problems", "problems/examples/tamp2d_blocked.yaml",
                          "--algorithms", "adaptive", "--seeds", "1", "--max-time", "20",
                          "--success-cost", "1e9", "--out", str(out)])
    (row,) = json.loads(out.read_text())
    assert row["status"] == "solved" and row["anytime_costs"] == [row["cost"]]
    # A solve within the grace: the optimistic member's make_streams only.
    assert row["make_streams"] == 1 and row["member_rounds"] is None
    printed = capsys.readouterr().out
    assert "| tamp2d_blocked | adaptive | 1/1 | 1 | 1 |" in printed
