"""No long uninterruptible step runs after a solve's deadline (issue #19, hidden suite §4 E).

``ground_task`` sorted the initial facts of a large optimistic task in one ``sorted`` call:
no deadline check runs inside it, and it holds the GIL, so neither the worker nor the
watchdog noticed the deadline until it ended (robots2_4: 7 s late under load). The sorts on
that path are now done in bounded chunks with deadline checks. The tests count the work
done *after* the deadline, so they do not depend on the machine's speed or load: object
names count their ordering comparisons, and the deadline passes at a chosen comparison.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from ltamp_cli.planner.algorithms.common import PlannerConfig, initial_state
from ltamp_cli.planner.algorithms.optimistic import optimistic_evaluation
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.result import TIMEOUT
from ltamp_cli.planner.search import clock
from ltamp_cli.planner.search.clock import SORT_CHUNK, SearchTimeout, sorted_before
from ltamp_cli.planner.search.ground import ground_task

REPO = Path(__file__).resolve().parents[2]
FACTS = 60_000
# Comparisons a sort of one chunk makes at most (n log2 n), plus a merge's slack.
CHUNK_COMPARISONS = SORT_CHUNK * SORT_CHUNK.bit_length() + 10_000


class Clocked(str):
    """An object name whose ordering comparisons are counted; at the ``deadline_at``-th one
    the planner's clock (faked: :func:`fake_clock`) jumps past the deadline, so the deadline
    passes inside a sort, at the same point on any machine."""

    count = 0
    deadline_at = -1
    now = 0.0
    after_deadline = 0

    def __lt__(self, other: object) -> bool:
        cls = Clocked
        cls.count += 1
        if cls.count == cls.deadline_at:
            cls.now = DEADLINE + 1.0
        elif cls.count > cls.deadline_at > 0:
            cls.after_deadline += 1
        return str.__lt__(self, other)  # type: ignore[operator]

    __hash__ = str.__hash__

    @classmethod
    def arm(cls, deadline_at: int) -> None:
        cls.count, cls.deadline_at, cls.now, cls.after_deadline = 0, deadline_at, 0.0, 0


DEADLINE = 1.0


class _FakeTime:
    @staticmethod
    def perf_counter() -> float:
        return Clocked.now


@pytest.fixture
def fake_clock(monkeypatch: pytest.MonkeyPatch) -> None:
    """The deadline checks read :attr:`Clocked.now` instead of the machine's clock."""
    monkeypatch.setattr(clock, "time", _FakeTime)


def _facts(count: int, seed: int = 0) -> list[tuple[str, ...]]:
    """Distinct ``cfree`` facts in a random order (same-predicate: the sort compares the
    names, which are what count)."""
    rng = random.Random(seed)
    facts = [("cfree", Clocked(f"p{i}"), Clocked(f"q{i % 97}")) for i in range(count)]
    rng.shuffle(facts)
    return facts


def test_sorted_before_equals_sorted_with_and_without_key() -> None:
    rng = random.Random(3)
    items = [(rng.randrange(50), rng.choice("abc"), i) for i in range(3 * SORT_CHUNK + 17)]
    assert sorted_before(items, float("inf")) == sorted(items)
    key = lambda item: item[:2]  # noqa: E731  ties: stability decides, as in sorted()
    assert sorted_before(items, float("inf"), key=key) == sorted(items, key=key)
    assert sorted_before(items[:10], float("inf")) == sorted(items[:10])
    with pytest.raises(SearchTimeout):
        sorted_before(items, -1.0)


def test_grounding_stops_sorting_initial_facts_soon_after_the_deadline(
        fake_clock: None) -> None:
    facts = _facts(FACTS)
    # The deadline passes after a few chunks' worth of comparisons: far into what one
    # sort of every fact (~10^6 comparisons) would still do.
    Clocked.arm(deadline_at=3 * CHUNK_COMPARISONS)
    with pytest.raises(SearchTimeout):
        ground_task([], [], facts, {}, deadline=DEADLINE)
    assert Clocked.count >= Clocked.deadline_at  # the deadline did pass inside the sort
    assert Clocked.after_deadline <= CHUNK_COMPARISONS


def test_grounding_order_is_unchanged_without_a_deadline() -> None:
    facts = _facts(3 * SORT_CHUNK + 5)
    Clocked.arm(deadline_at=-1)
    grounding = ground_task([], [], facts, {})
    assert grounding.reachable == set(facts)


def test_optimistic_evaluation_stops_sorting_known_facts_soon_after_the_deadline(
        fake_clock: None) -> None:
    problem = load_problem(REPO / "problems" / "examples" / "tamp2d_uniform_tight_2.yaml")
    state = initial_state(problem, PlannerConfig(seed=0, max_time=DEADLINE))
    for fact in _facts(FACTS):
        state.facts.add(fact)
    state.start_time = 0.0  # on the fake clock: the deadline is DEADLINE
    Clocked.arm(deadline_at=3 * CHUNK_COMPARISONS)
    with pytest.raises(SearchTimeout):
        optimistic_evaluation(state, 0, None)  # type: ignore[arg-type]
    assert Clocked.count >= Clocked.deadline_at
    assert Clocked.after_deadline <= CHUNK_COMPARISONS


def test_abandoned_result_lists_no_facts() -> None:
    problem = load_problem(REPO / "problems" / "examples" / "tamp2d_uniform_tight_2.yaml")
    state = initial_state(problem, PlannerConfig(seed=0))
    for fact in _facts(2000):
        state.facts.add(fact)
    assert state.result(TIMEOUT, None, known_facts=False).certificate.facts == []
    assert len(state.result(TIMEOUT, None).certificate.facts) == len(state.facts.members)
