"""Conventions every ``ltamp`` command follows: ``--json``, ``--version``, ``-v/-q``, help
without an empty error line, Ctrl-C, built-in problem names, plugin discovery and the thread
limits of the Python API."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from importlib.metadata import version
from pathlib import Path

import click
import pytest
import typer

from ltamp_cli.backends import BUILTIN_BACKENDS, discover_backends
from ltamp_cli.cli.app import build_app
from ltamp_cli.extras import missing_module_hint
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.shipped import builtin_problems, resolve_problem_path
from ltamp_cli.threads import limited_threads

REPO_ROOT = Path(__file__).resolve().parents[2]


def ltamp(cwd: Path, *argv: str, pythonpath: tuple[Path, ...] = ()
          ) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, XDG_CACHE_HOME=str(cwd / "cache"), COLUMNS="200",
               PYTHONPATH=os.pathsep.join(str(p) for p in (*pythonpath, REPO_ROOT)))
    return subprocess.run([sys.executable, "-m", "ltamp_cli", *argv], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=240, check=False)


def leaf_commands(command: click.Command, prefix: str = "") -> dict[str, click.Command]:
    children = getattr(command, "commands", None)
    if not children:
        return {prefix.strip(): command}
    found: dict[str, click.Command] = {}
    for name, child in children.items():
        found.update(leaf_commands(child, f"{prefix} {name}"))
    return found


def test_every_command_accepts_json() -> None:
    commands = leaf_commands(typer.main.get_command(build_app()))
    assert {"solve", "problems", "check", "collect", "skills", "train", "evaluate", "sample",
            "import", "tell", "plot level-set", "plot curves"} <= set(commands)
    without = [name for name, command in commands.items()
               if not any("--json" in param.opts for param in command.params)]
    assert without == []


def test_version_help_and_usage_lines(tmp_path: Path) -> None:
    shown = ltamp(tmp_path, "--version")
    assert shown.returncode == 0 and shown.stdout.strip() == f"ltamp {version('ltamp')}"
    for argv in ((), ("plot",)):
        bare = ltamp(tmp_path, *argv)
        assert bare.returncode == 0 and "Usage" in bare.stdout and "error" not in bare.stderr
    both = ltamp(tmp_path, "-q", "-v", "problems")
    assert both.returncode == 2 and both.stderr.count("\n") == 1
    assert both.stderr.startswith("ltamp: error: -v/--verbose and -q/--quiet")
    assert "ltamp[ray]" in ltamp(tmp_path, "collect", "--help").stdout
    completion = ltamp(tmp_path, "--help").stdout
    assert "--install-completion" in completion and "--show-completion" in completion
    env = dict(os.environ, PYTHONPATH=str(REPO_ROOT), _LTAMP_COMPLETE="complete_bash",
               COMP_WORDS="ltamp so", COMP_CWORD="1")
    completed = subprocess.run([sys.executable, "-m", "ltamp_cli"], cwd=tmp_path, env=env,
                               capture_output=True, text=True, timeout=120, check=False)
    assert completed.stdout.split() == ["solve"]  # what bash completes `ltamp so` to


def test_human_text_by_default_json_on_request(tmp_path: Path) -> None:
    human = ltamp(tmp_path, "check", "examples/tamp2d_blocked")
    assert human.returncode == 0 and human.stdout.startswith("ok: domain tamp2d")
    checked = json.loads(ltamp(tmp_path, "check", "examples/tamp2d_blocked", "--json").stdout)
    assert checked["ok"] and checked["domain"] == "tamp2d" and checked["streams"] > 0


def test_ctrl_c_prints_one_line_and_exits_130(tmp_path: Path) -> None:
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path / "cache"),
               PYTHONPATH=str(REPO_ROOT))
    # A solve plus Box2D execution of the coffee task runs for well over the wait below.
    process = subprocess.Popen(
        [sys.executable, "-m", "ltamp_cli", "solve", "kitchen2d/coffee", "--backend", "box2d"],
        cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(6)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130 and err == "ltamp: interrupted\n"


def test_builtin_problem_names(tmp_path: Path) -> None:
    names = builtin_problems()
    shipped = {p.relative_to(REPO_ROOT / "problems").with_suffix("").as_posix()
               for p in (REPO_ROOT / "problems").rglob("*.yaml")}
    assert set(names) == shipped and "kitchen2d/coffee" in names
    assert names["examples/tamp2d_blocked"].summary.startswith("2D pick-and-place")
    for spelling in ("kitchen2d/coffee", "kitchen2d/coffee.yaml", "problems/kitchen2d/coffee"):
        assert resolve_problem_path(spelling) == names["kitchen2d/coffee"].path
    assert resolve_problem_path("kitchen2d/nope") == Path("kitchen2d/nope")
    local = tmp_path / "kitchen2d" / "coffee.yaml"  # a file of that name wins over the name
    local.parent.mkdir()
    local.write_text("x")
    assert resolve_problem_path(local) == local
    assert load_problem("examples/tamp2d_blocked").path == str(
        names["examples/tamp2d_blocked"].path)
    listed = ltamp(tmp_path, "problems", "--json")
    assert {p["name"] for p in json.loads(listed.stdout)["problems"]} == shipped
    solved = ltamp(tmp_path, "solve", "examples/tamp2d_blocked", "--seed", "0", "--json")
    assert solved.returncode == 0 and json.loads(solved.stdout)["status"] == "solved"
    missing = ltamp(tmp_path, "solve", "kitchen2d/nope")
    assert missing.returncode == 2 and missing.stderr.count("\n") == 1


def test_backends_of_installed_distributions_are_discovered(tmp_path: Path) -> None:
    """A distribution's ``ltamp.backends`` entry point (a dist-info folder on the path, as
    pip leaves it) adds a backend; built-in names cannot be replaced."""
    site = tmp_path / "site"
    info = site / "ltamp_tiny-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: ltamp-tiny\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[ltamp.backends]\ntiny = ltamp_tiny:make_backend\nsynthetic = ltamp_tiny:nope\n")
    (site / "ltamp_tiny.py").write_text(
        "from ltamp_cli.backends.synthetic import make_backend as _make\n\n"
        "def make_backend(**options):\n"
        "    backend = _make(**options)\n"
        "    backend.name = 'tiny'\n"
        "    return backend\n")
    listed = ltamp(tmp_path, "skills", "--json", pythonpath=(site,))
    backends = {b["name"]: b for b in json.loads(listed.stdout)["backends"]}
    assert backends["tiny"]["available"] and backends["synthetic"]["available"]
    assert {s["name"] for s in backends["tiny"]["skills"]} >= {"moving2d"}
    collected = ltamp(tmp_path, "collect", "moving2d", "--backend", "tiny", "-n", "5", "--out",
                      "t.jsonl", "--json", pythonpath=(site,))
    assert collected.returncode == 0 and json.loads(collected.stdout)["added"] == 5
    assert discover_backends().keys() >= BUILTIN_BACKENDS.keys()


def test_missing_optional_modules_name_their_extra(tmp_path: Path) -> None:
    assert missing_module_hint(ModuleNotFoundError("x", name="numpy")) == ""
    # A folder first on the path where importing pybullet fails as if it were not installed.
    absent = tmp_path / "absent" / "pybullet"
    absent.mkdir(parents=True)
    (absent / "__init__.py").write_text(
        "raise ModuleNotFoundError(\"No module named 'pybullet'\", name='pybullet')\n")
    hint = "install it with: pip install 'ltamp[pybullet]'"
    for argv in (("solve", "kitchen3d/wash"),
                 ("train", "pour", "--backend", "pybullet", "--out", "m")):
        done = ltamp(tmp_path, *argv, pythonpath=(absent.parent,))
        assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
        assert done.stderr.startswith("ltamp: error: ") and hint in done.stderr
    listed = ltamp(tmp_path, "skills", "--json", pythonpath=(absent.parent,))
    backends = {b["name"]: b for b in json.loads(listed.stdout)["backends"]}
    assert not backends["pybullet"]["available"] and hint in backends["pybullet"]["error"]
    assert backends["box2d"]["available"]


THREAD_DOMAIN = """\
(define (domain probe)
  (:predicates (Seen ?x))
  (:action see :parameters (?x) :precondition (Seen ?x) :effect ()))
"""
THREAD_STREAMS = """\
(define (stream probe)
  (:stream observe :outputs (?x) :certified (Seen ?x)))
"""
THREAD_BINDINGS = """\
import torch
from threadpoolctl import threadpool_info

SEEN = []


def make_streams(world, rng):
    def observe():
        pools = [pool["num_threads"] for pool in threadpool_info()]
        SEEN.append((torch.get_num_threads(), max(pools, default=1)))
        yield ("x",)
    return {"observe": observe}
"""


def test_api_solve_limits_thread_pools_like_the_cli(tmp_path: Path) -> None:
    torch = pytest.importorskip("torch")
    (tmp_path / "domain.pddl").write_text(THREAD_DOMAIN.replace(":effect ()",
                                                                ":effect (Seen ?x)"))
    (tmp_path / "stream.pddl").write_text(THREAD_STREAMS)
    (tmp_path / "probe.py").write_text(THREAD_BINDINGS)
    (tmp_path / "problem.yaml").write_text(
        "domain: .\nbindings: probe.py\nobjects: {}\ninit: []\ngoal: (exists (?x) (Seen ?x))\n")
    problem = load_problem(tmp_path / "problem.yaml")
    bindings = next(m for m in sys.modules.values()
                    if getattr(m, "__file__", None) == str((tmp_path / "probe.py").resolve()))
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        result = solve(problem, PlannerConfig(seed=0, max_time=20))
        assert result.solved and bindings.SEEN and set(bindings.SEEN) == {(1, 1)}
        assert torch.get_num_threads() == 2  # restored afterwards
        with limited_threads(None):
            assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)


def test_progress_on_a_terminal_only(tmp_path: Path) -> None:
    """Executing a plan draws a progress line on stderr when it is a terminal (in pipes
    nothing is drawn: see the Ctrl-C test)."""
    import pty

    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path / "cache"), PYTHONPATH=str(REPO_ROOT))
    leader, follower = pty.openpty()
    process = subprocess.Popen(
        [sys.executable, "-m", "ltamp_cli", "solve", "kitchen2d/fill_and_serve", "--seed", "3",
         "--backend", "box2d", "--json"],
        cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=follower, text=True)
    os.close(follower)
    chunks = []
    while True:
        try:
            chunk = os.read(leader, 4096)
        except OSError:  # the terminal closed: the process ended
            break
        if not chunk:
            break
        chunks.append(chunk)
    out, _ = process.communicate(timeout=300)
    os.close(leader)
    assert process.returncode == 0 and json.loads(out)["goal_holds"]
    drawn = b"".join(chunks).decode(errors="replace")
    assert "executing" in drawn and "actions on box2d" in drawn


def test_quiet_hides_progress_and_verbose_shows_info(monkeypatch: pytest.MonkeyPatch) -> None:
    import logging

    from ltamp_cli.cli.conventions import CliSettings, configure_logging, progress_enabled

    class Terminal:
        def isatty(self) -> bool:
            return True

    monkeypatch.setattr(sys, "stderr", Terminal())
    try:
        configure_logging(CliSettings(verbosity=-1))
        assert not progress_enabled()
        configure_logging(CliSettings(verbosity=0))
        assert progress_enabled() and not logging.getLogger("ltamp").isEnabledFor(logging.INFO)
        configure_logging(CliSettings(verbosity=2))
        assert logging.getLogger("ltamp.x").isEnabledFor(logging.DEBUG)
    finally:
        monkeypatch.undo()  # the real stderr again, before logging is reset to it
        logging.basicConfig(level=logging.WARNING, force=True)
        logging.captureWarnings(False)


def test_api_learning_limits_thread_pools_like_the_cli() -> None:
    torch = pytest.importorskip("torch")
    from ltamp_cli.backends import load_backend
    from ltamp_cli.learning.active import LearningConfig, learn_online

    synthetic = load_backend("synthetic")
    seen: list[int] = []

    class Recording:
        """The synthetic backend, noting the torch threads available to each trial."""

        name = "recording"

        def __getattr__(self, attribute: str):  # type: ignore[no-untyped-def]
            return getattr(synthetic, attribute)

        def run_trial(self, skill, context, control, seed):  # type: ignore[no-untyped-def]
            seen.append(torch.get_num_threads())
            return synthetic.run_trial(skill, context, control, seed)

    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        config = LearningConfig(strategy="lse2", budget=12, init=4, seed=0)
        result = learn_online(Recording(), "moving2d", config)
        assert len(result.records) == 12 and set(seen) == {1}
        assert torch.get_num_threads() == 2
        seen.clear()
        learn_online(Recording(), "moving2d", LearningConfig(budget=5, init=5, threads=None))
        assert set(seen) == {2}
    finally:
        torch.set_num_threads(before)
