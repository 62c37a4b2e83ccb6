"""``FactIndex.of_sorted`` (issue #19: groundings and optimistic evaluations bulk-load their
initial facts) builds the index that adding the facts one by one builds: the same members,
the same facts per predicate in the same order, and the same join results afterwards."""

from __future__ import annotations

import random

from ltamp_cli.planner.search.ground import FactIndex, join
from ltamp_cli.planner.search.normalize import LiftedLiteral


def test_bulk_load_equals_adding_one_by_one() -> None:
    rng = random.Random(0)
    literals = [LiftedLiteral("P", ("?x", "?y")), LiftedLiteral("Q", ("?y", "a"))]
    for _ in range(50):
        facts = sorted({(rng.choice("PQR"), *rng.choices("abc", k=2)) for _ in range(12)})
        one_by_one = FactIndex()
        for fact in facts:
            one_by_one.add(fact)
        bulk = FactIndex.of_sorted(facts)
        assert bulk.members == one_by_one.members
        assert dict(bulk.by_predicate) == {p: v for p, v in one_by_one.by_predicate.items()
                                           if v}
        # Later additions and lazily built argument indexes behave alike.
        for index in (one_by_one, bulk):
            index.lookup("P", (1,), ("a",))
            index.add(("P", "c", "a"))
            index.add(("Q", "a", "a"))
        assert bulk.lookup("P", (1,), ("a",)) == one_by_one.lookup("P", (1,), ("a",))
        assert list(join(literals, bulk)) == list(join(literals, one_by_one))
