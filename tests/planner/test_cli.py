"""``ltamp solve``: exit codes, ``--json`` output, one-line errors (through a subprocess,
but for one in-process case)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path

import pytest
from line_domain import LINE_BINDINGS, LINE_DOMAIN, LINE_STREAMS

MakeProblem = Callable[..., Path]
REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "problems" / "examples"


def ltamp(*args: str | Path, cwd: Path | None = None, hash_seed: str = "0"
          ) -> subprocess.CompletedProcess[str]:
    # A fixed PYTHONHASHSEED by default; test_plan_independent_of_hash_seed varies it.
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO),
           "PYTHONHASHSEED": hash_seed}
    return subprocess.run([sys.executable, "-m", "ltamp_cli", "solve", *map(str, args)],
                          capture_output=True, text=True, timeout=120, env=env,
                          cwd=cwd or REPO)


def assert_bad_input(run: subprocess.CompletedProcess[str], *fragments: str) -> None:
    assert run.returncode == 2, (run.stdout, run.stderr)
    assert "Traceback" not in run.stderr and "Traceback" not in run.stdout
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1, run.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


def test_json_output_for_a_solved_example(tmp_path: Path) -> None:
    run = ltamp(EXAMPLES / "tamp2d_blocked.yaml", "--json", "--seed", "3", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)  # exactly one JSON object
    assert {"status", "plan", "cost", "time_s", "stats"} <= data.keys()
    assert data["status"] == "solved"
    assert data["plan"] and all({"name", "args"} <= step.keys() for step in data["plan"])
    assert data["plan"][-1]["name"] == "place"
    # args are the real values: the pose of block a is a float inside the goal [4, 7]
    # (a is 2 wide), the grasp and configuration are (x, y) pairs.
    block, pose, grasp, conf = data["plan"][-1]["args"]
    assert block == "a" and 5.0 <= pose <= 6.0
    assert conf == [pytest.approx(pose + grasp[0]), pytest.approx(grasp[1])]
    assert data["cost"] == pytest.approx(sum(step["cost"] for step in data["plan"]))
    assert data["stats"]["algorithm"] == "adaptive"  # the default  # the default
    assert not list(tmp_path.iterdir())  # nothing written into the working directory


def test_human_output_and_algorithm_option() -> None:
    run = ltamp(EXAMPLES / "blocksworld.yaml", "--algorithm", "incremental")
    assert run.returncode == 0, run.stderr
    first, *steps = run.stdout.strip().splitlines()
    assert first.startswith("status: solved")
    assert steps and steps[0].lstrip().startswith("1. ")


def test_same_seed_same_json_plan() -> None:
    runs = [ltamp(EXAMPLES / "tamp2d_4blocks.yaml", "--json", "--seed", "5",
                  "--algorithm", "incremental") for _ in range(2)]
    plans = [json.loads(run.stdout)["plan"] for run in runs]
    assert plans[0] == plans[1]


@pytest.mark.parametrize(("example", "algorithm"), [("blocksworld", "incremental"),
                                                     ("tamp2d_4blocks", "binding")])
def test_plan_independent_of_hash_seed(example: str, algorithm: str) -> None:
    # tamp2d: sampled values, and samplers that remember what they have seen, must not
    # depend on string hashing either.
    plans = {json.dumps(json.loads(ltamp(EXAMPLES / f"{example}.yaml", "--json", "--algorithm",
                                         algorithm, "--seed", "5", "--no-stats",
                                         hash_seed=str(h)).stdout)["plan"])
             for h in range(1, 5)}
    assert len(plans) == 1


def test_pddl_problem_file_with_domain_option(tmp_path: Path) -> None:
    problem = tmp_path / "tower.pddl"
    problem.write_text("(define (problem tower) (:domain blocksworld)\n"
                       "  (:objects a b - block)\n"
                       "  (:init (ontable a) (ontable b) (clear a) (clear b) (handempty))\n"
                       "  (:goal (on a b)))\n")
    run = ltamp(problem, "--domain", REPO / "domains" / "blocksworld", "--json")
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    assert [(s["name"], s["args"]) for s in data["plan"]] == [("pick-up", ["a"]),
                                                               ("stack", ["a", "b"])]
    assert data["cost"] == 2.0
    assert_bad_input(ltamp(problem), "needs its domain folder")




def line_yaml(top: str, goal: int, extra: str = "") -> str:
    return (f"domain: dom\nbindings: bindings.py\nworld: {{top: {top}, goal: {goal}}}\n"
            "objects: {p0: 0}\ninit: [\"(Pos p0)\", \"(At p0)\"]\n"
            f"goal: (exists (?p) (and (At ?p) (Goal ?p)))\n{extra}")


def test_infeasible_exits_1(make_problem: MakeProblem) -> None:
    path = make_problem(LINE_DOMAIN, line_yaml("3", 7), LINE_STREAMS, LINE_BINDINGS)
    run = ltamp(path, "--json")
    assert run.returncode == 1, run.stderr
    data = json.loads(run.stdout)
    assert data["status"] == "infeasible" and data["plan"] is None


def test_timeout_exits_1(make_problem: MakeProblem) -> None:
    path = make_problem(LINE_DOMAIN, line_yaml("null", -1), LINE_STREAMS, LINE_BINDINGS)
    run = ltamp(path, "--json", "--max-time", "0.3", "--algorithm", "incremental")
    assert run.returncode == 1, run.stderr
    assert json.loads(run.stdout)["status"] == "timeout"


def test_problem_planner_defaults_and_override(make_problem: MakeProblem) -> None:
    path = make_problem(LINE_DOMAIN, line_yaml("5", 2, "planner: {algorithm: incremental}\n"),
                        LINE_STREAMS, LINE_BINDINGS)
    run = ltamp(path, "--json")
    assert run.returncode == 0 and json.loads(run.stdout)["stats"]["algorithm"] == "incremental"
    run = ltamp(path, "--json", "--algorithm", "focused")
    assert run.returncode == 0 and json.loads(run.stdout)["stats"]["algorithm"] == "focused"
    assert [s["args"] for s in json.loads(run.stdout)["plan"]] == [[0, 1], [1, 2]]


GOOD_YAML = line_yaml("5", 2)


# make_problem strips the leading newline of the PDDL texts: "(define" is on line 1.


@pytest.mark.parametrize(("domain", "streams", "problem", "bindings", "where", "fragment"), [
    # malformed PDDL
    (LINE_DOMAIN.replace("(At ?q) (not", "(At ?q (not"), LINE_STREAMS, GOOD_YAML,
     LINE_BINDINGS, "domain.pddl:1:1:", "unclosed '('"),
    # malformed stream file
    (LINE_DOMAIN, LINE_STREAMS.replace(":outputs (?q)", ":outputs ?q"), GOOD_YAML,
     LINE_BINDINGS, "stream.pddl:5:14:", "expected '(' starting the outputs of 'next'"),
    # malformed YAML
    (LINE_DOMAIN, LINE_STREAMS, GOOD_YAML.replace("objects: {p0: 0}", "objects: {p0: 0"),
     LINE_BINDINGS, "problem.yaml:", "invalid YAML"),
    # unknown predicate
    (LINE_DOMAIN.replace("(Step ?p ?q))\n    :effect", "(Stp ?p ?q))\n    :effect"),
     LINE_STREAMS, GOOD_YAML, LINE_BINDINGS, "domain.pddl:5:32:",
     "unknown predicate 'stp' in action 'move'"),
    # unknown type
    (LINE_DOMAIN.replace("(Pos ?p)", "(Pos ?p - pose)", 1), LINE_STREAMS, GOOD_YAML,
     LINE_BINDINGS, "domain.pddl:2:16:", "unknown type 'pose'"),
    # arity mismatch
    (LINE_DOMAIN, LINE_STREAMS.replace(":certified (Goal ?p)", ":certified (Goal ?p ?p)"),
     GOOD_YAML, LINE_BINDINGS, "stream.pddl:10:16:", "predicate 'goal' takes 1 argument(s)"),
    (LINE_DOMAIN, LINE_STREAMS, GOOD_YAML.replace("(At p0)", "(At p0 p0)"), LINE_BINDINGS,
     "problem.yaml:5:", "predicate 'at' takes 1 argument(s), got 2"),
    # stream with no Python binding
    (LINE_DOMAIN, LINE_STREAMS, GOOD_YAML, LINE_BINDINGS.replace('"test-goal"', '"goal-test"'),
     "stream.pddl:7:3:", "stream 'test-goal' has no Python binding"),
    # binding module that fails to import
    (LINE_DOMAIN, LINE_STREAMS, GOOD_YAML, "import numpy\nfrom numpy import no_such_name\n",
     "problem.yaml:2:11:", "failed to import: ImportError"),
])
def test_bad_input_exits_2_with_one_line(make_problem: MakeProblem, domain: str, streams: str,
                                         problem: str, bindings: str, where: str,
                                         fragment: str) -> None:
    path = make_problem(domain, problem, streams, bindings)
    run = ltamp(path)
    assert_bad_input(run, where, fragment)
    if where:
        assert str(path.parent) in run.stderr  # the full path of the offending file


def test_bad_options_exit_2(make_problem: MakeProblem) -> None:
    path = make_problem(LINE_DOMAIN, GOOD_YAML, LINE_STREAMS, LINE_BINDINGS)
    assert_bad_input(ltamp(path, "--algorithm", "astar"), "unknown algorithm 'astar'")
    assert_bad_input(ltamp(path, "--max-time", "0"), "--max-time: expected a positive number")
    assert_bad_input(ltamp(path.parent / "missing.yaml"), "missing.yaml", "file not found")


def test_stream_that_raises_exits_2(make_problem: MakeProblem) -> None:
    bindings = textwrap.dedent("""
        def make_streams(world, rng):
            def next_(p):
                raise ValueError("sampler exploded")
                yield
            return {"next": next_, "test-goal": lambda p: False}
    """)
    path = make_problem(LINE_DOMAIN, GOOD_YAML, LINE_STREAMS, bindings)
    assert_bad_input(ltamp(path), "stream 'next' raised ValueError: sampler exploded")


def test_solve_with_learned_streams_runs_numerics_on_one_thread() -> None:
    # Small GPs run several times slower on 2 threads (field facts); CI's OMP_NUM_THREADS=1
    # hides that, so start from 2 threads in-process.
    import torch
    from threadpoolctl import threadpool_info, threadpool_limits
    from typer.testing import CliRunner

    from ltamp_cli.cli.app import build_app

    def blas_threads() -> set[int]:
        return {pool["num_threads"] for pool in threadpool_info()
                if pool["user_api"] == "blas"}

    torch_before = torch.get_num_threads()
    with threadpool_limits(limits=2, user_api="blas"):
        torch.set_num_threads(2)
        try:
            assert blas_threads() == {2}
            run = CliRunner().invoke(build_app(), [
                "solve", str(EXAMPLES / "synthetic_goodregion.yaml"), "--seed", "0",
                "--no-stats"])
            assert run.exit_code == 0, run.output
            assert torch.get_num_threads() == 1
            assert blas_threads() == {1}
        finally:
            torch.set_num_threads(torch_before)
