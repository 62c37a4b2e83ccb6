"""bench/planner.py on small cases: validated plans, repeats that agree (also warm, whose
persisted statistics each repeat starts from), and the machine reference in its JSON."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench import planner


def test_planner_bench_writes_validated_repeated_runs_and_the_machine_reference(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "planner.json"
    planner.main(["--examples", "blocksworld,tamp2d_blocked", "--seeds", "2",
                  "--algorithms", "incremental,focused", "--histories", "cold,warm",
                  "--repeats", "2", "--out", str(out)])
    report = json.loads(out.read_text())
    assert {(r["example"], r["algorithm"], r["history"]) for r in report["summary"]} == {
        (e, a, h) for e in ("blocksworld", "tamp2d_blocked") for a in ("incremental", "focused")
        for h in ("cold", "warm")}
    # Every repeat of a seed found the same plan (else the run is marked invalid).
    assert all(row["solved"] == row["valid"] == 2 for row in report["summary"])
    assert len(report["runs"]) == 16 and not report["targets"]  # no target for these two
    for run in report["runs"]:
        assert run["cpu_s"] == min(run["cpu_s_repeats"]) and len(run["cpu_s_repeats"]) == 2
    reference = report["machine_reference"]
    assert 0 < reference["before_s"] < 5 and 0 < reference["after_s"] < 5
    assert "machine reference workload" in capsys.readouterr().out


def test_repeats_that_find_different_plans_are_reported(monkeypatch: pytest.MonkeyPatch
                                                        ) -> None:
    from dataclasses import replace

    from ltamp_cli.planner.problem import load_problem

    problem = load_problem(planner.EXAMPLES / "tamp2d_blocked.yaml")
    seeds = iter(range(100))
    solve = planner.solve
    # A planner that is not deterministic: each repeat samples with another seed.
    monkeypatch.setattr(planner, "solve",
                        lambda problem, config: solve(problem, replace(config, seed=next(seeds))))
    row = planner.run_one(problem, "incremental", 0, 10.0, repeats=3)
    assert row["valid"] is False
    assert any("different plans" in error for error in row["errors"])


def test_uniform_suite_reports_targets_overruns_and_a_scaling_plot(tmp_path: Path) -> None:
    out, plot = tmp_path / "uniform.json", tmp_path / "scaling.png"
    planner.main(["--suite", "uniform", "--examples",
                  "tamp2d_uniform_blocked_2,tamp2d_uniform_tight_2", "--seeds", "2",
                  "--algorithms", "adaptive", "--max-time", "30",
                  "--out", str(out), "--plot", str(plot)])
    report = json.loads(out.read_text())
    assert report["suite"] == "uniform" and report["overruns"] == 0
    assert report["max_time_s"] == 30.0 and report["seeds"] == 2
    assert {t["example"] for t in report["targets"]} == {"tamp2d_uniform_blocked_2",
                                                        "tamp2d_uniform_tight_2"}
    assert all(t["target_median_s"] == 0.1 for t in report["targets"])
    assert all(row["solved"] == row["valid"] == 2 and row["max_cpu_s"] >= row["median_cpu_s"]
               for row in report["summary"])
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # The full suite: 2 layouts x 4 sizes and the fluent kitchen, each a shipped problem.
    names = planner.uniform_examples()
    assert len(names) == 9 and all((planner.EXAMPLES / f"{n}.yaml").exists() for n in names)


def test_a_refused_algorithm_is_reported_not_run(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """kitchen_fluent has a :fluents stream, which incremental refuses: the suite goes on
    (it used to stop with the refusal's traceback, losing every other run)."""
    out = tmp_path / "planner.json"
    planner.main(["--examples", "kitchen_fluent,blocksworld", "--seeds", "1",
                  "--algorithms", "incremental", "--histories", "cold,warm", "--repeats", "1",
                  "--out", str(out)])
    report = json.loads(out.read_text())
    assert [(r["example"], r["algorithm"]) for r in report["refused"]] == [
        ("kitchen_fluent", "incremental")]
    assert ":fluents" in report["refused"][0]["reason"]
    # refused once, not once per history; blocksworld ran cold and warm
    assert [(r["example"], r["history"]) for r in report["runs"]] == [
        ("blocksworld", "cold"), ("blocksworld", "warm")]
    assert "REFUSED: kitchen_fluent / incremental" in capsys.readouterr().out
