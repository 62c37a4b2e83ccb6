"""A budgeted search is not repeated on a task that grounds as one whose search ran out."""

from __future__ import annotations

import time
from pathlib import Path

from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.search.solve import grounding_signature, plan_discrete

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"


def test_same_grounded_task_is_skipped_and_a_changed_one_is_searched() -> None:
    problem = load_problem(EXAMPLES / "blocksworld.yaml")
    objects = {name: type_name for name, (type_name, _) in problem.objects.items()}
    init = [(atom.predicate, *atom.args) for atom in problem.init]
    deadline = time.perf_counter() + 60

    def run(facts, skip=None):
        return plan_discrete(problem.domain, objects, facts, {}, problem.goal, deadline,
                             algorithm="lazy-greedy", max_expansions=1,
                             skip_if_grounded_as=skip)

    first = run(init)
    assert first.capped and not first.skipped  # 8 blocks: not solved in one expansion
    signature = grounding_signature(first.grounding)
    again = run(init, signature)
    assert again.skipped and again.capped and again.outcome.expanded == 0
    # A fact no action or axiom uses does not change the search: still skipped.
    assert run([*init, ("unused-fact", "x")], signature).skipped
    # Removing an initial fact changes the ground actions: not skipped.
    changed = run(init[1:], signature)
    assert grounding_signature(changed.grounding) != signature and not changed.skipped

