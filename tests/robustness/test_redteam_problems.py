"""The three red-team problems (``redteam_problems.py``) through the PDDLStream API and
through ``ltamp solve`` on YAML: every algorithm solves them or refuses in one line, plans
replay on the Python values, and a solve returns within ``max_time`` + 1 s."""

from __future__ import annotations

import io
import json
import sys
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

import redteam_problems as problems

from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream import solve
from ltamp_cli.planner.algorithms.common import ALGORITHMS, PlannerConfig
from ltamp_cli.planner.api import solve as plan
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

# The rover's route stream declares :fluents, which the incremental algorithm refuses.
REFUSED = {("rover", "incremental"): ":fluents"}
MAX_TIME = 30.0


@pytest.mark.parametrize("algorithm", ALGORITHMS)
@pytest.mark.parametrize("name", sorted(problems.BUILDERS))
def test_python_api(tmp_path: Path, name: str, algorithm: str) -> None:
    problem, check = problems.BUILDERS[name](tmp_path, seed=0)
    if (name, algorithm) in REFUSED:
        with pytest.raises(InputError, match=REFUSED[(name, algorithm)]) as error:
            solve(problem, algorithm=algorithm, max_time=MAX_TIME, verbose=False)
        assert "\n" not in str(error.value)
        return
    start = time.perf_counter()
    solution = solve(problem, algorithm=algorithm, max_time=MAX_TIME, verbose=False)
    assert time.perf_counter() - start <= MAX_TIME + 1.0
    assert solution.plan is not None, (name, algorithm)
    check(solution.plan)


@pytest.mark.parametrize("algorithm", ALGORITHMS)
@pytest.mark.parametrize("name", sorted(problems.BUILDERS))
def test_yaml_route(tmp_path: Path, name: str, algorithm: str) -> None:
    path = problems.write_yaml_problem(tmp_path, name)
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["solve", str(path), "--algorithm", algorithm, "--max-time", str(MAX_TIME),
              "--seed", "0", "--no-stats", "--json"])
    if (name, algorithm) in REFUSED:
        lines = err.getvalue().strip().splitlines()
        assert done.value.code == 2 and len(lines) == 1, lines
        assert REFUSED[(name, algorithm)] in lines[0]
        return
    assert done.value.code in (0, None), err.getvalue()[-500:]
    result = json.loads(out.getvalue())
    assert result["status"] == "solved"
    # the same plan, validated against the problem with its bindings
    loaded = load_problem(path)
    again = plan(loaded, PlannerConfig(algorithm=algorithm, max_time=MAX_TIME, seed=0))
    assert again.solved and validate_plan(loaded, again).valid


def test_a_solve_returns_within_max_time_plus_one_second(tmp_path: Path) -> None:
    """A route stream that sleeps: the solve still returns in max_time + 1 s."""
    problem, _ = problems.rover_problem(tmp_path, seed=0)
    slow = dict(problem.stream_map)
    route = slow["plan-route"]

    def sleepy(*args, **kwargs):  # type: ignore[no-untyped-def]
        time.sleep(5.0)
        return route(*args, **kwargs)

    slow["plan-route"] = sleepy
    start = time.perf_counter()
    solution = solve(problem._replace(stream_map=slow), algorithm="adaptive", max_time=1.5,
                     verbose=False)
    assert time.perf_counter() - start <= 2.5
    assert solution.plan is None


def test_validator_finds_bindings_whatever_their_case(tmp_path: Path) -> None:
    """The planner matches binding names case-insensitively; the validator did not: a
    solved plan whose cost function is bound as 'Length' was reported invalid ("no Python
    binding for 'length'")."""
    path = problems.write_yaml_problem(tmp_path, "conveyor")
    loaded = load_problem(path)
    result = plan(loaded, PlannerConfig(algorithm="incremental", max_time=MAX_TIME, seed=0))
    assert result.solved
    samplers = problems.conveyor_samplers(0)
    shouting = {name.upper(): function for name, function in samplers.items()}
    assert validate_plan(loaded, result, streams=shouting).valid


def test_check_counts_the_stream_file_s_own_streams(tmp_path: Path) -> None:
    """The conveyor's stream file declares 2 streams; the negated collision test the loader
    adds is not one of them."""
    path = problems.write_yaml_problem(tmp_path, "conveyor")
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["check", str(path), "--json"])
    assert done.value.code in (0, None), err.getvalue()
    assert json.loads(out.getvalue())["streams"] == 2
