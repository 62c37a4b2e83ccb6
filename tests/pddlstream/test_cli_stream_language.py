"""``ltamp solve`` reads stream files as PDDLStream does, and refuses (exit 2, one line at
``file:line:col``) what an algorithm does not support instead of answering "infeasible"."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

DOMAIN = """
(define (domain tidy)
  (:predicates (Block ?b) (OnTable ?b) (Route ?b ?r) (Stored ?b))
  (:action lift :parameters (?b) :precondition (and (Block ?b) (OnTable ?b))
    :effect (not (OnTable ?b)))
  (:action store :parameters (?b ?r) :precondition (and (Route ?b ?r) (OnTable ?b) (Safe ?r))
    :effect (and (Stored ?b) (not (OnTable ?b)))))
"""
# The route of "a" is blocked while "b" is on the table (the stream sees the state);
# (Safe ?r) comes from a rule over (Checked ?r): predicates of the stream file only.
STREAMS = """
(define (stream tidy)
  (:stream Find-Route
    :inputs (?b) :domain (Block ?b)
    :fluents (OnTable)
    :outputs (?r) :certified (and (Route ?b ?r) (Checked ?r)))
  (:rule :inputs (?r) :domain (Checked ?r) :certified (Safe ?r)))
"""
BINDINGS = """
def make_streams(world, rng):
    def find_route(block, fluents=()):
        others = {fact[1] for fact in fluents if fact[0] == "ontable"} - {block}
        if block == "a" and "b" in others:
            return None
        return ("route-" + block,)
    return {"FIND-ROUTE": find_route}
"""
PROBLEM = """
domain: dom
bindings: bindings.py
objects: {a: null, b: null}
init: ["(Block a)", "(Block b)", "(OnTable a)", "(OnTable b)"]
goal: (Stored a)
"""


def write_problem(folder: Path) -> Path:
    (folder / "dom").mkdir()
    (folder / "dom" / "domain.pddl").write_text(textwrap.dedent(DOMAIN).lstrip())
    (folder / "dom" / "stream.pddl").write_text(textwrap.dedent(STREAMS).lstrip())
    (folder / "bindings.py").write_text(textwrap.dedent(BINDINGS).lstrip())
    path = folder / "problem.yaml"
    path.write_text(textwrap.dedent(PROBLEM).lstrip())
    return path


def ltamp_solve(path: Path, *options: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO),
           "XDG_CACHE_HOME": str(path.parent / "cache")}
    return subprocess.run([sys.executable, "-m", "ltamp_cli", "solve", str(path), *options],
                          capture_output=True, text=True, timeout=120, env=env, cwd=path.parent)


def test_fluent_streams_rules_and_case_insensitive_bindings_solve(tmp_path: Path) -> None:
    """(The other algorithms are checked through the Python API in test_dropin_api.py.)"""
    run = ltamp_solve(write_problem(tmp_path), "--algorithm", "adaptive")
    assert run.returncode == 0, (run.stdout, run.stderr)
    assert run.stdout.index("1. lift b") < run.stdout.index("2. store a route-a")


def test_incremental_refuses_fluent_streams_before_solving(tmp_path: Path) -> None:
    path = write_problem(tmp_path)
    run = ltamp_solve(path, "--algorithm", "incremental")
    assert run.returncode == 2, (run.stdout, run.stderr)
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in run.stderr, run.stderr
    assert f"{tmp_path / 'dom' / 'stream.pddl'}:4:5: " in lines[0], lines[0]
    assert "'find-route' declares :fluents" in lines[0] and "adaptive" in lines[0]
