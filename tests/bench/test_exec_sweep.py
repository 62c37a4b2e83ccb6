"""bench/exec_sweep.py: rows from both executors' reports, the reasons given for failures,
which earlier rows are reused, the summary's counts, bad input; one real 2D seed."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from bench import exec_sweep
from ltamp_cli.backends.execution import ExecutionReport

ROOT = Path(__file__).resolve().parents[2]


def test_goal_facts_of_both_executors_become_one_list() -> None:
    box2d = {"(On cup coaster)": {"holds": True, "x": 1.0}, "(Stirred cup)": {"holds": False}}
    assert exec_sweep.goal_facts(box2d) == [{"fact": "(On cup coaster)", "holds": True, "x": 1.0},
                                            {"fact": "(Stirred cup)", "holds": False}]
    pyb = [{"fact": "(contains bowl water)", "holds": True, "fraction": 1.0}]
    assert exec_sweep.goal_facts(pyb) == pyb
    assert exec_sweep.goal_facts(None) == []


def test_why_names_the_failed_step_else_the_failed_facts() -> None:
    failed_step = ExecutionReport(False, False, {
        "steps": [{"step": 1, "action": "move", "ok": True},
                  {"step": 2, "action": "push", "ok": False, "error": "came to rest 0.049 m"}],
        "goal": [{"fact": "(contains bowl water)", "holds": False, "fraction": 0.0}]})
    row = exec_sweep.execution_row(failed_step, 1.0, 2.0)
    assert not row["executed"] and not row["goal_holds"]
    assert row["why"] == "step 2 push: came to rest 0.049 m"
    spilled = ExecutionReport(True, False, {
        "steps": [{"step": 1, "action": "pour", "ok": True}],
        "goal": {"(Contains bowl water)": {"holds": False, "fraction": 0.43},
                 "(On cup coaster)": {"holds": True}}})
    row = exec_sweep.execution_row(spilled, 1.0, 2.0)
    assert row["executed"] and row["why"].startswith("(Contains bowl water) fails")
    assert "0.43" in row["why"] and "coaster" not in row["why"]
    held = ExecutionReport(True, True, {"goal": [{"fact": "(x)", "holds": True}]})
    assert exec_sweep.execution_row(held, 1.0, 2.0)["why"] is None


def test_reuse_copies_only_the_cells_engine_and_listed_seeds(tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch
                                                             ) -> None:
    old = tmp_path / "old.jsonl"
    verdict = {"cpu_s": 3.0, "goal_holds": True, "goal": [{"fact": "(g)", "holds": True}]}
    rows = [{"problem": "wash", "seed": 0, "status": "solved", "plan_cpu_s": 1.0,
             "pybullet": verdict, "sapien": {**verdict, "goal_holds": False}},
            {"problem": "wash", "seed": 1, "status": "solved", "plan_cpu_s": 1.0,
             "pybullet": verdict},                       # never executed on SAPIEN
            {"problem": "wash", "seed": 2, "status": "timeout", "plan_cpu_s": 9.0},
            {"problem": "unclog", "seed": 3, "status": "solved", "sapien": verdict},
            {"problem": "wash", "seed": 7, "status": "solved", "sapien": verdict}]
    old.write_text("".join(json.dumps(r) + "\n" for r in rows))
    cell = exec_sweep.Cell("kitchen3d", "wash", "sapien")
    monkeypatch.setattr(exec_sweep, "RESULTS", tmp_path)
    monkeypatch.setitem(exec_sweep.REUSE, cell.key, [("old.jsonl", (0, 1, 2, 3))])
    cache = cell.cache(tmp_path / "sweep")
    assert exec_sweep.reuse_rows(cell, cache) == 2
    got = exec_sweep.read_cache(cache)
    assert sorted(got) == [0, 2]
    assert got[0]["execution"]["goal_holds"] is False and "pybullet" not in got[0]
    assert got[0]["source"] == "old.jsonl" and got[2]["status"] == "timeout"
    assert exec_sweep.reuse_rows(cell, cache) == 0  # already there: nothing appended twice
    summary = exec_sweep.cell_summary(cell, got, (0, 1, 2))
    assert (summary["planned"], summary["goal_holds"], summary["seeds"]) == (1, 0, [0, 2])
    assert [f["seed"] for f in summary["failures"]] == [0, 2]
    assert summary["failures"][1]["why"] == "not planned (timeout)"


def test_an_unknown_cell_is_one_error_line(tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, str(ROOT / "bench/exec_sweep.py"), "--only",
                           "kitchen3d/coffee:box2d", "--cache-dir", str(tmp_path),
                           "--out", str(tmp_path / "s.json")],
                          capture_output=True, text=True, cwd=tmp_path, check=False)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "unknown cell 'kitchen3d/coffee:box2d'" in done.stderr


def test_a_2d_seed_is_planned_and_executed_in_box2d() -> None:
    cell = exec_sweep.Cell("kitchen2d", "task1_push_off", "box2d")
    row = exec_sweep.run_seed(cell, 0, 60.0)
    assert row["status"] == "solved" and "push" in " ".join(row["actions"]).lower()
    ex = row["execution"]
    assert ex["executed"] and ex["goal_holds"] and ex["why"] is None
    assert ex["goal"] and all(fact["holds"] for fact in ex["goal"])
    assert ex["sim_time_s"] > 0.0
