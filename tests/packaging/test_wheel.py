"""An installed wheel carries the shipped domains, problems and models.

The wheel is built from a copy of the sources (pip builds in the source tree), installed
without dependencies into a fresh venv whose only link to the test's environment is a
``.pth`` line naming that environment's site-packages (so torch is not reinstalled; ``.pth``
files there, such as an editable ltamp's, are not run). Every command then runs from an
empty directory without ``PYTHONPATH``, so only the installed package can answer.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
SOURCES = ("pyproject.toml", "setup.py", "MANIFEST.in", "README.md", "ltamp_cli", "domains",
           "problems", "models")
TIMEOUT_S = 600


def run(argv: list[str], cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=TIMEOUT_S, check=False)


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    """(the fresh venv's bin folder, a clean environment for its commands)."""
    work = tmp_path_factory.mktemp("wheel")
    source = work / "source"
    source.mkdir()
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "_shipped")
    for name in SOURCES:
        origin = REPO_ROOT / name
        if origin.is_dir():
            shutil.copytree(origin, source / name, ignore=ignore)
        else:
            shutil.copy2(origin, source / name)
    env = {key: value for key, value in os.environ.items()
           if key not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env.update(XDG_CACHE_HOME=str(work / "cache"), OMP_NUM_THREADS="1")
    built = run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps",
                 "--no-build-isolation", "--no-index", "--disable-pip-version-check",
                 "--wheel-dir", str(work / "dist"), str(source)], work, env)
    assert built.returncode == 0, built.stderr[-3000:]
    wheel = next((work / "dist").glob("ltamp-*.whl"))
    venv = work / "venv"
    made = run([sys.executable, "-m", "venv", "--without-pip", str(venv)], work, env)
    assert made.returncode == 0, made.stderr
    python = venv / "bin" / "python"
    purelib = run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()"
                   "['purelib'])"], work, env).stdout.strip()
    Path(purelib, "_ltamp_test_dependencies.pth").write_text(
        sysconfig.get_paths()["purelib"] + "\n")
    added = run([sys.executable, "-m", "pip", "--python", str(python), "install", "--quiet",
                 "--no-deps", "--no-index", "--disable-pip-version-check", str(wheel)],
                work, env)
    assert added.returncode == 0, added.stderr[-3000:]
    return venv / "bin", env


@pytest.mark.slow  # ~55 s of CPU: the wheel build and the coffee solve executed in Box2D
def test_installed_ltamp_solves_a_builtin_problem_elsewhere(installed, tmp_path: Path) -> None:
    bin_dir, env = installed
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    where = run([str(bin_dir / "python"), "-c", "import ltamp_cli; print(ltamp_cli.__file__)"],
                elsewhere, env)
    assert Path(where.stdout.strip()).is_relative_to(bin_dir.parent), where.stdout

    version = run([str(bin_dir / "ltamp"), "--version"], elsewhere, env)
    assert version.returncode == 0 and version.stdout.strip() == "ltamp 0.1.0"

    listed = run([str(bin_dir / "ltamp"), "problems", "--json"], elsewhere, env)
    problems = {p["name"]: Path(p["path"]) for p in json.loads(listed.stdout)["problems"]}
    assert {"kitchen2d/coffee", "kitchen3d/wash", "examples/tamp2d_blocked"} <= set(problems)
    assert all(path.is_relative_to(bin_dir.parent) for path in problems.values())

    checked = run([str(bin_dir / "ltamp"), "check", "kitchen2d/coffee", "--json"], elsewhere,
                  env)
    assert checked.returncode == 0 and json.loads(checked.stdout)["domain"] == "kitchen2d"

    solved = run([str(bin_dir / "ltamp"), "solve", "kitchen2d/coffee", "--backend", "box2d",
                  "--seed", "1", "--json"], elsewhere, env)
    assert solved.returncode == 0, solved.stderr[-3000:]
    result = json.loads(solved.stdout)
    assert result["status"] == "solved" and result["executed"] and result["goal_holds"]
    assert sorted(p.name for p in elsewhere.iterdir()) == []  # nothing written here
