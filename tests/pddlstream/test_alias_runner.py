"""`ltamp pddlstream run` / `python -m ltamp_cli.pddlstream` on scripts written in
PDDLStream's style (tests/pddlstream/alias_scripts.py), each in a fresh interpreter: the
plan the script prints, its exit code and argv, the one-line errors, and that without the
runner nothing serves `pddlstream`."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from alias_scripts import write_courier
from runner_subprocess import run_runner as run

REPO = Path(__file__).resolve().parents[2]
PLAN = ["1) drive", "2) load", "3) drive", "4) unload"]


def plan_lines(stdout: str) -> list[str]:
    return [line.split(" ")[0] + " " + line.split(" ")[1] for line in stdout.splitlines()
            if line[:1].isdigit() and ") " in line]


@pytest.fixture()
def courier(tmp_path: Path) -> Path:
    return write_courier(tmp_path / "courier")


@pytest.mark.parametrize("cli", [True, False], ids=["ltamp-pddlstream-run", "python-m"])
def test_script_runs_unmodified_and_prints_its_plan(courier: Path, tmp_path: Path,
                                                    cli: bool) -> None:
    done = run([str(courier), "-a", "focused"], cwd=tmp_path, cli=cli)
    assert done.returncode == 0, done.stderr
    assert "Algorithm: focused" in done.stdout  # the script's own argv
    assert "Solved: True" in done.stdout
    assert plan_lines(done.stdout) == PLAN
    # The planner had to skip the drop spot at 12 (no route from 3) and use 7: cost
    # 3 (drive 0->3) + 1 + 4 (drive 3->7) + 1.
    assert "Drop at: 7.0" in done.stdout and "Cost: 9" in done.stdout
    assert done.stderr == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["courier"]  # nothing written


def test_exit_code_is_the_scripts(courier: Path, tmp_path: Path) -> None:
    done = run([str(courier), "--exit", "5"], cwd=tmp_path)
    assert done.returncode == 5, done.stderr
    assert "Solved: True" in done.stdout
    reported = run(["--json", str(courier), "--exit", "4"], cwd=tmp_path)
    assert reported.returncode == 4
    summary = json.loads(reported.stdout.splitlines()[-1])  # after the script's own output
    assert summary["exit_code"] == 4 and summary["error"] is None
    assert summary["script"] == str(courier) and summary["cpu_s"] > 0
    missing = run(["--json", str(courier.parent / "missing.py")], cwd=tmp_path)
    assert missing.returncode == 2 and missing.stderr.count("\n") == 1
    assert json.loads(missing.stdout)["error"].startswith(f"{courier.parent / 'missing.py'}:4:")


def test_the_scripts_own_error_gives_its_traceback(courier: Path, tmp_path: Path) -> None:
    done = run([str(courier), "--fail"], cwd=tmp_path)
    assert done.returncode == 1
    lines = done.stderr.splitlines()
    assert lines[0] == "Traceback (most recent call last):"
    assert f'File "{courier}"' in done.stderr and "runpy" not in done.stderr
    assert lines[-2] == "ValueError: the script's own bug"
    assert lines[-1].startswith(f"ltamp: the script {courier} failed in its own code")


def test_plan_constraints_and_analyze_goal_through_the_alias(courier: Path,
                                                             tmp_path: Path) -> None:
    """``pddlstream.algorithms.constraints`` and ``meta.analyze_goal`` as a script imports
    them: the goal back-chains to the fluent initial facts; the skeleton's ``?x`` makes the
    last drive end where the parcel is unloaded."""
    done = run([str(courier.parent / "constrained.py")], cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "Facts: ['at', 'parcelat']" in done.stdout
    assert plan_lines(done.stdout) == PLAN
    drives = [line for line in done.stdout.splitlines() if ") drive " in line]
    unload = next(line for line in done.stdout.splitlines() if ") unload " in line)
    assert drives[-1].split(" ", 3)[-1].endswith(unload.split(" ", 3)[-1])


def test_missing_ltamp_equivalent_is_one_line_and_exit_2(courier: Path, tmp_path: Path
                                                        ) -> None:
    script = courier.parent / "missing.py"
    done = run([str(script)], cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr == (
        f"ltamp: error: {script}:4: pddlstream.algorithms.skeleton.SkeletonQueue is not "
        "provided by ltamp's pddlstream alias: one of PDDLStream's planner internals; ltamp's "
        "planner has its own (solve(..., algorithm='adaptive') manages skeletons)\n")
    strict = run(["--strict", str(script)], cwd=tmp_path)
    assert strict.returncode == 2
    assert strict.stderr.startswith(f"ltamp: error: {script}:2: pddlstream.algorithms."
                                    "skeleton.SkeletonQueue is not provided")
    assert strict.stderr.count("\n") == 1


def test_unknown_pddlstream_name_and_bad_problem_are_one_line(courier: Path, tmp_path: Path
                                                             ) -> None:
    unknown = run([str(courier.parent / "unknown.py")], cwd=tmp_path)
    assert unknown.returncode == 2
    assert unknown.stderr == (
        f"ltamp: error: {courier.parent / 'unknown.py'}:2: cannot import "
        "'get_problem_internals' from pddlstream.algorithms.downward: ltamp's pddlstream "
        "alias does not provide it (see docs/porting-from-pddlstream.md for what it "
        "provides)\n")
    broken = run([str(courier.parent / "broken.py")], cwd=tmp_path)
    assert broken.returncode == 2
    assert broken.stderr.startswith(f"ltamp: error: {courier.parent / 'broken.pddl'}:")
    assert broken.stderr.count("\n") == 1
    absent = run([str(tmp_path / "absent.py")], cwd=tmp_path)
    assert (absent.returncode, absent.stderr) == (
        2, f"ltamp: error: {tmp_path / 'absent.py'}: no such script\n")


def test_module_mode_runs_like_python_m(tmp_path: Path) -> None:
    write_courier(tmp_path, package="courier_pkg")
    done = run(["-m", "courier_pkg.run", "-a", "binding"], cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "Algorithm: binding" in done.stdout and plan_lines(done.stdout) == PLAN
    absent = run(["-m", "no_such_pkg.run"], cwd=tmp_path, cli=False)
    assert absent.returncode == 2
    assert absent.stderr.startswith("ltamp: error: -m no_such_pkg.run: no module named "
                                    "'no_such_pkg'")


def test_real_pddlstream_is_not_shadowed_unless_forced(courier: Path, tmp_path: Path) -> None:
    real = courier.parent / "pddlstream"
    real.mkdir()
    (real / "__init__.py").write_text("")
    refused = run([str(courier)], cwd=tmp_path)
    assert refused.returncode == 2
    assert refused.stderr.startswith(f"ltamp: error: a real PDDLStream is importable "
                                     f"({real / '__init__.py'})")
    assert "--force" in refused.stderr and refused.stderr.count("\n") == 1
    forced = run(["--force", str(courier)], cwd=tmp_path)
    assert forced.returncode == 0, forced.stderr
    assert plan_lines(forced.stdout) == PLAN


def test_without_the_runner_nothing_serves_pddlstream(courier: Path, tmp_path: Path) -> None:
    """The same script under plain Python, even after importing ltamp's drop-in API, fails
    at its first `pddlstream` import: only the runner or install() serve it."""
    code = ("import runpy, sys\n"
            "import ltamp_cli.pddlstream\n"
            f"sys.argv = [{str(courier)!r}]\n"
            f"runpy.run_path({str(courier)!r}, run_name='__main__')\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=180, cwd=tmp_path,
                          env={"PATH": os.environ.get("PATH", "/usr/bin:/bin"),
                               "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"})
    assert done.returncode == 1
    assert done.stderr.splitlines()[-1] == "ModuleNotFoundError: No module named 'pddlstream'"
