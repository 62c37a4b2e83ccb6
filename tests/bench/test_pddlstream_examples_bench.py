"""bench/pddlstream_examples.py on a stand-in checkout written here (never a real PDDLStream
checkout in the tests): the runner's alias serves ``pddlstream.*`` from ltamp_cli.pddlstream
(shadowing the checkout's own package), the example's own module and samplers run
unmodified in a child process, and the table/JSON report it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

RUN_PY = """
from pddlstream.algorithms.meta import solve, create_parser
from pddlstream.language.constants import PDDLProblem, print_solution
from pddlstream.language.generator import from_gen_fn, from_test
from pddlstream.utils import read, get_file_path
from pddlstream.language.optimizer import OptimizerOutput  # unused: must not stop loading
from examples.hop.primitives import hops

def get_problem():
    stream_map = {'sample-hop': from_gen_fn(hops), 'test-goal': from_test(lambda x: x == 3)}
    return PDDLProblem(read(get_file_path(__file__, 'domain.pddl')), {},
                       read(get_file_path(__file__, 'stream.pddl')), stream_map,
                       [('Num', 0), ('At', 0)], ('Done',))

def main():
    args = create_parser().parse_args()
    print_solution(solve(get_problem(), algorithm=args.algorithm, planner='max-astar'))

if __name__ == '__main__':
    main()
"""
USES_INTERNALS_PY = """
from pddlstream.algorithms.meta import solve
from pddlstream.algorithms.skeleton import SkeletonQueue

def main():
    SkeletonQueue(None, None)
    solve(None)

if __name__ == '__main__':
    main()
"""
PRIMITIVES = """
def hops(x):
    yield (x + 1,)
"""
DOMAIN = """
(define (domain hop)
  (:predicates (Num ?x) (At ?x) (Hop ?x ?y) (Goal ?x) (Done))
  (:action hop :parameters (?x ?y) :precondition (and (Hop ?x ?y) (At ?x))
    :effect (and (At ?y) (not (At ?x))))
  (:action finish :parameters (?x) :precondition (and (At ?x) (Goal ?x)) :effect (Done)))
"""
STREAM = """
(define (stream hop)
  (:stream sample-hop :inputs (?x) :domain (Num ?x) :outputs (?y)
    :certified (and (Num ?y) (Hop ?x ?y)))
  (:stream test-goal :inputs (?x) :domain (Num ?x) :certified (Goal ?x)))
"""


def write_checkout(root: Path) -> None:
    files = {"pddlstream/__init__.py": "", "pddlstream/utils.py": "INF = float('inf')\n",
             "pddlstream/algorithms/meta.py": "", "pddlstream/algorithms/downward.py": "",
             "pddlstream/language/constants.py": "", "pddlstream/language/generator.py": "",
             "examples/__init__.py": "", "examples/hop/__init__.py": "",
             "examples/hop/run.py": RUN_PY, "examples/hop/internals.py": USES_INTERNALS_PY,
             "examples/hop/primitives.py": PRIMITIVES,
             "examples/hop/domain.pddl": DOMAIN, "examples/hop/stream.pddl": STREAM}
    for relative, text in files.items():
        path = root / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text).lstrip())


def bench(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO),
           "XDG_CACHE_HOME": str(cwd / "cache")}
    return subprocess.run([sys.executable, str(REPO / "bench" / "pddlstream_examples.py"),
                           *args], capture_output=True, text=True, timeout=180, env=env,
                          cwd=cwd)


def test_stand_in_checkout_is_loaded_and_solved(tmp_path: Path) -> None:
    checkout = tmp_path / "pddlstream"
    write_checkout(checkout)
    out = tmp_path / "result.json"
    run = bench(str(checkout), "--max-time", "30", "--out", str(out), cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    internals, row = json.loads(out.read_text())["examples"]
    assert row["example"] == "hop/run.py"
    assert row["loaded"] and row["solved"], row
    assert row["plan_length"] == 4  # hop, hop, hop, finish
    assert row["exit_code"] == 0 and "error" not in row
    assert internals["example"] == "hop/internals.py"
    assert not internals["loaded"] and internals["exit_code"] == 2
    assert internals["error"].startswith(
        f"{checkout / 'examples' / 'hop' / 'internals.py'}:5: pddlstream.algorithms.skeleton."
        "SkeletonQueue is not provided by ltamp's pddlstream alias"), internals
    assert "1/2 loaded, 1/2 solved" in run.stdout


def test_missing_checkout_is_skipped_with_a_message(tmp_path: Path) -> None:
    run = bench(str(tmp_path / "absent"), cwd=tmp_path)
    assert run.returncode == 0
    assert "no PDDLStream checkout" in run.stdout and "skipped" in run.stdout
