"""``python -m bench.paper --only X`` into a folder with a run.json folds the new run into
the earlier record: notes kept, wall/CPU seconds of experiments and units added, the newest
error kept, invocations counted (the units' work is stubbed: only the bookkeeping runs)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

import bench.paper.__main__ as paper


def _entry(wall: float, cpu: float, error: str = "") -> dict[str, Any]:
    return {"wall_s": wall, "cpu_s": cpu, "error": error}


def _rerun(monkeypatch: pytest.MonkeyPatch, out: Path, result: tuple[str, float, float, str]
           ) -> dict[str, Any]:
    """Run ``main`` for coffee only, its one unit reporting ``result``; the new run.json."""

    def fake_run_units(units: list[Any], ctx: Any, jobs: int, workers: int,
                       on_done: Any, merge: bool = True) -> list[tuple[str, float, float, str]]:
        assert merge  # a whole run merges its split experiments
        assert [u.key for u in units] == ["coffee"]
        on_done(result)
        return [result]

    monkeypatch.setattr(paper, "run_units", fake_run_units)
    paper.main(["--smoke", "--only", "coffee", "--out", str(out), "--no-report", "--jobs", "1"])
    return json.loads((out / "run.json").read_text())


def test_only_rerun_adds_times_keeps_notes_and_counts_invocations(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    earlier = {"mode": "smoke", "commit": "abc", "total_wall_s": 100.0, "total_cpu_s": 40.0,
               "jobs": 2, "notes": ["al2d ran on abc"],
               "experiments": {"coffee": _entry(10.0, 5.0, "RuntimeError: boom"),
                               "al2d": _entry(70.0, 30.0)},
               "units": {"coffee": _entry(10.0, 5.0, "RuntimeError: boom"),
                         "al2d:pour": _entry(70.0, 30.0)}}
    (tmp_path / "run.json").write_text(json.dumps(earlier))
    record = _rerun(monkeypatch, tmp_path, ("coffee", 2.0, 1.5, ""))
    assert record["notes"] == ["al2d ran on abc"]
    assert record["invocations"] == 2
    assert record["experiments"]["coffee"] == _entry(12.0, 6.5, "")  # added; error cleared
    assert record["units"]["coffee"] == _entry(12.0, 6.5, "")
    assert record["experiments"]["al2d"] == _entry(70.0, 30.0)  # not rerun: untouched
    assert record["units"]["al2d:pour"] == _entry(70.0, 30.0)
    assert record["total_wall_s"] >= 100.0 and record["total_cpu_s"] >= 40.0
    assert record["jobs"] == 1 and record["commit"] != "abc"  # the newest run's
    # A third invocation fails: its error is the newest, its seconds still add up.
    record = _rerun(monkeypatch, tmp_path, ("coffee", 1.0, 0.5, "ValueError: again"))
    assert record["invocations"] == 3
    assert record["experiments"]["coffee"] == _entry(13.0, 7.0, "ValueError: again")
    assert record["notes"] == ["al2d ran on abc"]


def test_merge_run_records_copies_entries_present_in_one_run_only() -> None:
    earlier = {"experiments": {"a": _entry(1.0, 1.0)}, "units": {}}
    newer = {"experiments": {"b": _entry(2.0, 2.0, "x")}, "units": {"b": _entry(2.0, 2.0)},
             "total_wall_s": 2.0, "total_cpu_s": 2.0, "notes": ["new"]}
    record = paper.merge_run_records(earlier, newer)
    assert record["experiments"] == {"a": _entry(1.0, 1.0), "b": _entry(2.0, 2.0, "x")}
    assert record["units"] == {"b": _entry(2.0, 2.0)}
    assert record["invocations"] == 2 and record["notes"] == ["new"]
    assert earlier == {"experiments": {"a": _entry(1.0, 1.0)}, "units": {}}  # not modified
