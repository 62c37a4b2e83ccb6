"""Issue #18: an instance's complexity combines its inputs' levels with PDDLStream's rule,
the maximum (``COMPLEXITY_OP = max`` in its ``algorithms/common.py``; its instantiator and
skeleton queue use the same), not their sum.

The problem is written for this test: ``DEPTH`` layers of streams, the first making a value
from a seed, each next one combining two values of the layer below. With levels summed, a
value of layer k cost 2^k - 1 (its two inputs counted apart), so at six layers the only plan
was above ``max_complexity`` (20) and adaptive answered "no plan" in 0.02 s CPU: a wrong
"infeasible". With the maximum a value of layer k is at level k.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from ltamp_cli.pddlstream import PDDLProblem, from_fn, read, solve
from ltamp_cli.planner.algorithms.optimistic import instance_level


def layers_problem(folder: Path, depth: int) -> PDDLProblem:
    streams = ["(define (stream layers)",
               "  (:stream s1 :inputs (?o) :domain (Seed ?o) :outputs (?v)"
               " :certified (L1 ?v))"]
    for k in range(2, depth + 1):
        streams.append(f"  (:stream s{k} :inputs (?a ?b) :domain (and (L{k - 1} ?a)"
                       f" (L{k - 1} ?b)) :outputs (?c) :certified (L{k} ?c))")
    streams.append(")")
    predicates = " ".join(f"(L{k} ?x)" for k in range(1, depth + 1))
    domain = (f"(define (domain layers) (:requirements :strips)\n"
              f"  (:predicates (Seed ?o) {predicates} (Done))\n"
              f"  (:action finish :parameters (?x) :precondition (L{depth} ?x)"
              f" :effect (Done)))\n")
    (folder / "domain.pddl").write_text(domain)
    (folder / "stream.pddl").write_text("\n".join(streams) + "\n")
    stream_map = {"s1": from_fn(lambda seed: (seed + 1,))}
    for k in range(2, depth + 1):
        stream_map[f"s{k}"] = from_fn(lambda a, b: (a + b,))
    return PDDLProblem(read(folder / "domain.pddl"), {}, read(folder / "stream.pddl"),
                       stream_map, [("Seed", 0)], ("Done",))


@pytest.mark.parametrize("depth", [3, 6])
def test_deep_stream_tree_is_solved(tmp_path: Path, depth: int) -> None:
    solution = solve(layers_problem(tmp_path, depth), algorithm="adaptive", max_time=20.0,
                     verbose=False)
    assert solution.plan is not None
    # The value doubles at every layer above the first: 2^(depth - 1) from seed 0 + 1.
    assert [step.name for step in solution.plan] == ["finish"]
    assert solution.plan[0].args == (2 ** (depth - 1),)


def test_instance_level_is_the_highest_input_level() -> None:
    levels = {"#a": 3, "#b": 5}
    real = {"@x": 4, "@y": 7}
    assert instance_level(("#a", "#b"), levels, real) == 5
    assert instance_level(("#a", "#a", "@x"), levels, real) == 4
    assert instance_level(("#b", "@y", "c"), levels, real) == 7
    assert instance_level((), levels, real) == 0
