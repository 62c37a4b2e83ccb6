"""The stream-statistics cache: stays inside its folder, survives corruption and write
failures without costing the plan, and merges concurrent solves without losing calls."""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
from pathlib import Path

import pytest

from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.statistics import StreamStatistics, statistics_file_name
from ltamp_cli.planner.streams import StreamStats

REPO = Path(__file__).resolve().parents[2]
TAMP2D = REPO / "problems" / "examples" / "tamp2d_blocked.yaml"


@pytest.mark.parametrize("domain", ["../../x", "/abs/path/x", "..", "a/b\\c", "x" * 400,
                                    "", "é\udcff", "con.json"])
def test_statistics_files_stay_inside_the_cache(tmp_path, domain):
    cache = tmp_path / "cache"
    statistics = StreamStatistics.load(cache, domain)
    statistics.update({"s": StreamStats(calls=1, successes=1, outputs=1, time_s=0.1)})
    assert statistics.save()
    files = [path for path in tmp_path.rglob("*") if path.is_file()]
    assert {path.parent for path in files} == {cache}
    assert all(len(path.name.encode()) <= 100 for path in files)
    assert StreamStatistics.load(cache, domain).totals["s"]["calls"] == 1


def test_similar_domain_names_get_different_files():
    assert statistics_file_name("a/b") != statistics_file_name("a_b")


def test_a_pddl_domain_named_like_a_path_writes_only_into_the_cache(tmp_path):
    domain_dir = tmp_path / "domain"
    domain_dir.mkdir()
    source = (REPO / "domains" / "blocksworld" / "domain.pddl").read_text()
    (domain_dir / "domain.pddl").write_text(
        source.replace("(domain blocksworld)", "(domain ../../../victim)"))
    problem_pddl = (REPO / "domains" / "blocksworld" / "blocks8.pddl").read_text()
    (domain_dir / "p.pddl").write_text(problem_pddl.replace(":domain blocksworld",
                                                            ":domain ../../../victim"))
    problem = tmp_path / "p.yaml"
    problem.write_text("domain: domain\npddl_problem: domain/p.pddl\n")
    before = {path for path in tmp_path.rglob("*")}
    cache = tmp_path / "deep" / "er" / "cache"
    result = solve(load_problem(problem), PlannerConfig(max_time=30, statistics_dir=str(cache)))
    assert result.solved
    written = {path for path in tmp_path.rglob("*") if path.is_file()} - before
    assert written and all(path.parent == cache for path in written)


def test_a_corrupt_statistics_file_is_one_warning_and_replaced(tmp_path, caplog):
    problem = load_problem(TAMP2D)
    path = tmp_path / statistics_file_name(problem.domain.name)
    for garbage in ('{"streams": {"plan-motion": {"calls": "many"}}}', "\x00\xff{{", "[]",
                    '{"streams": {"a": {"calls": NaN}}}', "[" * 10000):
        path.write_text(garbage)
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="ltamp"):
            result = solve(problem, PlannerConfig(seed=0, max_time=30,
                                                  statistics_dir=str(tmp_path)))
        assert result.solved
        warnings = [r for r in caplog.records if r.levelno == logging.WARNING]
        assert len(warnings) == 1 and "corrupt" in warnings[0].getMessage()
        assert json.loads(path.read_text())["streams"]["plan-motion"]["calls"] > 0


def test_cache_write_failures_warn_and_keep_the_plan(tmp_path, caplog, monkeypatch):
    problem = load_problem(TAMP2D)
    blocker = tmp_path / "not-a-directory"
    blocker.write_text("")
    with caplog.at_level(logging.WARNING, logger="ltamp"):
        result = solve(problem, PlannerConfig(seed=0, max_time=30,
                                              statistics_dir=str(blocker / "cache")))
    assert result.solved and "not saved" in caplog.text

    def disk_full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    caplog.clear()
    monkeypatch.setattr(json, "dump", disk_full)
    cache = tmp_path / "cache"
    with caplog.at_level(logging.WARNING, logger="ltamp"):
        result = solve(problem, PlannerConfig(seed=0, max_time=30, statistics_dir=str(cache)))
    assert result.solved and "No space left" in caplog.text
    assert not list(cache.glob("*.tmp"))


def test_cli_solve_prints_the_plan_when_the_cache_is_unwritable(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    env = {**os.environ, "XDG_CACHE_HOME": str(blocker), "PYTHONPATH": str(REPO)}
    done = subprocess.run([sys.executable, "-m", "ltamp_cli", "solve", str(TAMP2D)],
                          capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "pick" in done.stdout
    assert done.stderr.count("\n") == 1 and "warning" in done.stderr


_SAVER = """
import sys
from ltamp_cli.planner.statistics import StreamStatistics
from ltamp_cli.planner.streams import StreamStats
for _ in range(int(sys.argv[2])):
    s = StreamStatistics.load(sys.argv[1], "shared")
    s.update({"s": StreamStats(calls=3, successes=1, outputs=1, time_s=0.5)})
    assert s.save()
"""


def test_concurrent_saves_lose_no_calls(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    workers = [subprocess.Popen([sys.executable, "-c", _SAVER, str(tmp_path), "10"], env=env)
               for _ in range(16)]
    assert all(worker.wait(timeout=120) == 0 for worker in workers)
    totals = StreamStatistics.load(tmp_path, "shared").totals["s"]
    assert totals["calls"] == 16 * 10 * 3 and totals["successes"] == 160
    assert not list(tmp_path.glob("*.tmp"))


@pytest.mark.slow
def test_concurrent_cli_solves_keep_every_stream_call(tmp_path):
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path), "PYTHONPATH": str(REPO),
           "OMP_NUM_THREADS": "1"}
    solves = [subprocess.Popen([sys.executable, "-m", "ltamp_cli", "solve", str(TAMP2D),
                                "--json", "--seed", str(seed)],
                               stdout=subprocess.PIPE, text=True, env=env)
              for seed in range(8)]
    calls: dict[str, int] = {}
    for process in solves:
        out, _ = process.communicate(timeout=300)
        assert process.returncode == 0
        streams = json.loads(out)["stats"]["streams"]
        for name, stats in streams.items():
            calls[name] = calls.get(name, 0) + stats["calls"]
    stored = StreamStatistics.load(tmp_path / "ltamp" / "stream-statistics",
                                   load_problem(TAMP2D).domain.name).totals
    assert {name: int(total["calls"]) for name, total in stored.items()} == calls
