"""A time limit of 1e308 s (or 1e9 s) is a valid positive number: the solve runs as if
unlimited. Before the fix the watchdog's join() raised OverflowError ("timestamp out of
range for platform time_t") for 1e308, and the Fast Downward subprocess ("timeout is too
large") for 1e9 and above, as tracebacks through 'ltamp solve'."""

from __future__ import annotations

import importlib.util
import io
import sys
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

import redteam_problems as problems

from ltamp_cli.cli.app import main
from ltamp_cli.pddlstream import solve

REPO = Path(__file__).resolve().parents[2]
SEARCHES = ["ff"] + (["fd"] if importlib.util.find_spec("fast_downward") else [])


@pytest.mark.parametrize("search", SEARCHES)
@pytest.mark.parametrize("max_time", [1e308, 1e9, float("inf")])
def test_python_api(tmp_path: Path, search: str, max_time: float) -> None:
    problem, check = problems.conveyor_problem(tmp_path, seed=0)
    solution = solve(problem, algorithm="adaptive", search=search, max_time=max_time,
                     verbose=False)
    assert solution.plan is not None
    check(solution.plan)


@pytest.mark.parametrize("search", SEARCHES)
def test_cli(search: str) -> None:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["solve", str(REPO / "problems" / "examples" / "kitchen_symbolic.yaml"),
              "--max-time", "1e308", "--search", search, "--no-stats", "--json"])
    assert done.value.code in (0, None), err.getvalue()[-400:]
    assert '"status": "solved"' in out.getvalue()
