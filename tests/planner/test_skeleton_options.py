"""Plan constraints written in a YAML problem or on the command line: several skeletons
(the plan follows one), ``?x`` variables shared between steps, ``max_cost`` (issue #18)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.validate import validate_plan

REPO = Path(__file__).resolve().parents[2]
BLOCKED = REPO / "problems" / "examples" / "tamp2d_blocked.yaml"
# b stands in the goal region: a cannot go there first (the first skeleton is impossible).
A_FIRST = ["move", "pick a ? ? ?", "move", "place a ? ? ?"]
# b out of the way, then a; ?g: a's grasp is the one it is placed with (the domain says so
# too), ?q: picking b where the robot arrived.
B_THEN_A = ["move ? ? ?q", "pick b ? ? ?q", "move", "place b ? ? ?", "move",
            "pick a ? ?g ?", "move", "place a ? ?g ?"]


def blocked_with(tmp_path: Path, planner: str) -> Path:
    """tamp2d_blocked.yaml with its paths made absolute and ``planner`` options."""
    text = BLOCKED.read_text().replace("../../", f"{REPO}/")
    text = text.replace("planner:\n  max_time: 30", f"planner:\n  max_time: 30\n{planner}")
    path = tmp_path / "blocked.yaml"
    path.write_text(text)
    return path


def test_yaml_skeletons_plan_follows_the_possible_one(tmp_path: Path) -> None:
    skeletons = json.dumps([A_FIRST, B_THEN_A])
    problem = load_problem(blocked_with(tmp_path, f"  skeletons: {skeletons}\n"))
    options = problem.planner_options
    result = solve(problem, PlannerConfig(seed=0, max_time=30,
                                          skeletons=tuple(tuple(s) for s in options["skeletons"])))
    assert result.solved, result.diagnostics
    assert [(s.name, s.args[0]) for s in result.plan if s.name in ("pick", "place")] == [
        ("pick", "b"), ("place", "b"), ("pick", "a"), ("place", "a")]
    assert len(result.plan) == len(B_THEN_A)
    assert result.plan[0].args[2] == result.plan[1].args[3]  # ?q
    assert validate_plan(problem, result).valid


def test_a_variable_binds_the_same_object_in_every_step() -> None:
    """``?p``: the plan ends placing a back at the pose it was picked from. Such a plan
    exists only if an earlier (gap) part already put a in the goal region, so the solve
    either finds that longer plan or runs out of time; "infeasible" would be wrong."""
    problem = load_problem(BLOCKED)
    skeleton = ("...", "pick a ?p ? ?", "...", "place a ?p ? ?")
    result = solve(problem, PlannerConfig(seed=0, max_time=4, skeleton=skeleton))
    assert result.status != "infeasible"
    if result.solved:
        assert validate_plan(problem, result).valid
        picks = [s for s in result.plan if s.name == "pick" and s.args[0] == "a"]
        assert result.plan[-1].name == "place" and result.plan[-1].args[0] == "a"
        assert any(p.args[1] == result.plan[-1].args[1] for p in picks)
        # the last pick of a is the skeleton's: a is held from it until the final place
        assert picks[-1].args[1] == result.plan[-1].args[1]
    free = ("...", "pick a ?p ? ?", "...", "place a ?r ? ?")
    solved = solve(problem, PlannerConfig(seed=0, max_time=30, skeleton=free))
    assert solved.solved and validate_plan(problem, solved).valid


def test_cli_max_cost_and_refusals(tmp_path: Path) -> None:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "XDG_CACHE_HOME": str(tmp_path)}
    path = blocked_with(tmp_path, "  max_cost: 0.5\n")
    bounded = subprocess.run([sys.executable, "-m", "ltamp_cli", "solve", str(path), "--json",
                              "--max-time", "10"], capture_output=True, text=True, env=env,
                             timeout=120)
    assert bounded.returncode == 1 and json.loads(bounded.stdout)["status"] != "solved"
    both = blocked_with(tmp_path, "  skeleton: [move]\n  skeletons: [[move]]\n")
    refused = subprocess.run([sys.executable, "-m", "ltamp_cli", "solve", str(both)],
                             capture_output=True, text=True, env=env, timeout=120)
    assert refused.returncode == 2
    assert "plan constraints given twice (skeleton and skeletons)" in refused.stderr
    assert len(refused.stderr.strip().splitlines()) == 1
    misspelt = blocked_with(tmp_path, "  skeletons: [[move], [move, 'pik a ? ? ?']]\n")
    refused = subprocess.run([sys.executable, "-m", "ltamp_cli", "solve", str(misspelt)],
                             capture_output=True, text=True, env=env, timeout=120)
    assert refused.returncode == 2
    assert refused.stderr.startswith(f"ltamp: error: {misspelt}:40:")
    assert "skeleton pattern 'pik': the domain has no such action" in refused.stderr


@pytest.mark.parametrize(("config", "message"), [
    (PlannerConfig(skeletons=(("move", "..."), ("move",))), "several skeletons must all"),
    (PlannerConfig(skeleton=("* a",)), "'*' (any action) takes no arguments"),
    (PlannerConfig(max_cost=float("nan")), "max cost: expected a number >= 0"),
])
def test_bad_constraints_are_refused(config: PlannerConfig, message: str) -> None:
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        solve(load_problem(BLOCKED), config)
