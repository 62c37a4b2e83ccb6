"""bench/planner.py on one small case: validated plans and the machine reference land in
the JSON it writes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench import planner


def test_planner_bench_writes_validated_runs_and_the_machine_reference(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "planner.json"
    planner.main(["--examples", "blocksworld,tamp2d_blocked", "--seeds", "2",
                  "--algorithms", "incremental,focused", "--histories", "cold",
                  "--out", str(out)])
    report = json.loads(out.read_text())
    assert {(row["example"], row["algorithm"]) for row in report["summary"]} == {
        (e, a) for e in ("blocksworld", "tamp2d_blocked") for a in ("incremental", "focused")}
    assert all(row["solved"] == row["valid"] == 2 for row in report["summary"])
    assert len(report["runs"]) == 8 and not report["targets"]  # no target for these two
    reference = report["machine_reference"]
    assert 0 < reference["before_s"] < 5 and 0 < reference["after_s"] < 5
    assert "machine reference workload" in capsys.readouterr().out
