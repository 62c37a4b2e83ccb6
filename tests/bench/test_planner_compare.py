"""bench/planner_compare.py: runs paired by seed, bootstrap CI of the
paired median difference, costlier/longer counts, and a one-line error for bad input."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from bench import planner_compare


def write(path: Path, cpu: list[float], costs: list[float], statuses: list[str]) -> Path:
    runs: list[dict[str, Any]] = [
        {"example": "toy", "algorithm": "adaptive", "history": "cold", "seed": seed,
         "status": status, "cpu_s": value, "cost": cost, "length": int(cost)}
        for seed, (value, cost, status) in enumerate(zip(cpu, costs, statuses, strict=True))]
    path.write_text(json.dumps({"benchmark": "planner", "runs": runs}))
    return path


def test_paired_rows(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = write(tmp_path / "b.json", [1.0, 2.0, 3.0, 4.0], [10, 10, 10, 10],
                   ["solved"] * 4)
    # every seed 0.5 s faster; seed 1 costlier and longer, seed 3 cheaper, seed 2 timed out
    after = write(tmp_path / "a.json", [0.5, 1.5, 2.5, 3.5], [10, 12, 10, 8],
                  ["solved", "solved", "timeout", "solved"])
    out = tmp_path / "rows.json"
    assert planner_compare.main([str(before), str(after), "--out", str(out)]) == 0
    (row,) = json.loads(out.read_text())
    assert row["solved_before"] == 4 and row["solved_after"] == 3
    assert row["paired_median_diff"] == pytest.approx(-0.5)
    assert row["paired_median_diff_ci95"] == pytest.approx([-0.5, -0.5])
    assert (row["costlier"], row["cheaper"], row["longer"], row["shorter"]) == (1, 1, 1, 1)
    assert row["timeouts_after"] == 1
    assert "| toy | adaptive | 4/4 / 3/4" in capsys.readouterr().out


def test_bootstrap_interval_contains_the_median_and_is_seeded() -> None:
    differences = [-0.3, -0.2, -0.1, 0.0, 0.4, -0.25, -0.15]
    low, high = planner_compare.bootstrap_median(differences)
    assert low <= sorted(differences)[3] <= high
    assert (low, high) == planner_compare.bootstrap_median(differences)


def test_a_file_that_is_not_a_result_is_a_one_line_error(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2")
    good = write(tmp_path / "a.json", [1.0], [1.0], ["solved"])
    assert planner_compare.main([str(bad), str(good)]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("error:") and "\n" not in error
