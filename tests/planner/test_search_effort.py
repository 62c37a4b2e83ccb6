"""The planner's effort-saving paths keep its answers: guarded universal auxiliaries,
semi-naive joins, expansion-budgeted searches."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import pytest

from ltamp_cli.planner.algorithms.common import ALGORITHMS, PlannerConfig, initial_state
from ltamp_cli.planner.algorithms.focused import solve_focused
from ltamp_cli.planner.algorithms.incremental import solve_incremental
from ltamp_cli.planner.algorithms.skeletons import solve_with_skeletons
from ltamp_cli.planner.problem import PlanningProblem, load_problem
from ltamp_cli.planner.result import PlanResult
from ltamp_cli.planner.search.ground import CostBound, FactIndex, join, join_new, join_tuples
from ltamp_cli.planner.search.normalize import LiftedLiteral
from ltamp_cli.planner.search.solve import DiscreteResult, plan_discrete
from ltamp_cli.planner.validate import validate_plan

MakeProblem = Callable[..., Path]
EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"

# A cup is finished once it holds every ingredient: the universal precondition becomes an
# auxiliary derived predicate, which should be grounded for cups only (not for the junk).
CUP_DOMAIN = """
(define (domain cups)
  (:types ingredient)
  (:predicates (Cup ?c) (Available ?m) (Has ?c ?m) (Done ?c))
  (:action add
    :parameters (?c - object ?m - ingredient)
    :precondition (and (Cup ?c) (Available ?m))
    :effect (Has ?c ?m))
  (:action finish
    :parameters (?c)
    :precondition (and (Cup ?c) (forall (?m - ingredient) (Has ?c ?m)))
    :effect (Done ?c)))
"""


def cup_problem(make_problem: MakeProblem, available: tuple[str, ...]) -> PlanningProblem:
    junk = ", ".join(f"junk{i}: null" for i in range(40))
    init = ", ".join(['"(Cup c1)"', *(f'"(Available {m})"' for m in available)])
    text = (f"domain: dom\nobjects: {{c1: null, {junk}, m1: {{type: ingredient}}, "
            f"m2: {{type: ingredient}}}}\ninit: [{init}]\ngoal: (Done c1)\n")
    return load_problem(make_problem(CUP_DOMAIN, text))


def discrete(problem: PlanningProblem, **options: object) -> DiscreteResult:
    objects = {name: type_name for name, (type_name, _) in problem.objects.items()}
    init = [(atom.predicate, *atom.args) for atom in problem.init]
    return plan_discrete(problem.domain, objects, init, {}, problem.goal,
                         time.perf_counter() + 30, **options)  # type: ignore[arg-type]


def test_universal_auxiliary_is_grounded_only_for_objects_the_action_can_use(
        make_problem: MakeProblem) -> None:
    result = discrete(cup_problem(make_problem, ("m1", "m2")))
    auxiliary = [a for a in result.grounding.axioms if a.head[0].startswith("%forall")]
    # Unguarded, the auxiliary would be grounded for all 43 objects x 2 ingredients.
    assert auxiliary and {a.head[1:] for a in auxiliary} == {("c1",)}
    assert result.actions is not None
    assert [a.name for a in result.actions][-1] == "finish"
    assert {a.args for a in result.actions if a.name == "add"} == {("c1", "m1"), ("c1", "m2")}


def test_guarded_universal_still_blocks_the_action(make_problem: MakeProblem) -> None:
    # m2 cannot be added, so the cup can never hold every ingredient.
    assert not discrete(cup_problem(make_problem, ("m1",))).solved


def test_join_new_yields_exactly_the_bindings_that_use_a_new_fact() -> None:
    index = FactIndex()
    for fact in [("Conf", "a"), ("Conf", "b"), ("Edge", "a", "b")]:
        index.add(fact)
    since = index.sizes()
    for fact in [("Conf", "c"), ("Edge", "b", "c"), ("Edge", "c", "a")]:
        index.add(fact)
    literals = [LiftedLiteral("Conf", ("?x",)), LiftedLiteral("Edge", ("?x", "?y")),
                LiftedLiteral("Conf", ("?y",))]
    everything = {(b["?x"], b["?y"]) for b in join(literals, index)}
    new = {(b["?x"], b["?y"]) for b in join_new(literals, index, since)}
    assert everything == {("a", "b"), ("b", "c"), ("c", "a")}
    assert new == everything - {("a", "b")}


def test_budgeted_search_reports_running_out() -> None:
    problem = load_problem(EXAMPLES / "blocksworld.yaml")
    capped = discrete(problem, algorithm="lazy-greedy", max_expansions=2)
    assert not capped.solved and capped.capped
    full = discrete(problem, algorithm="lazy-greedy")
    assert full.solved and not full.capped


def run_with_budget(problem: PlanningProblem, algorithm: str, budget: int) -> PlanResult:
    """Solve with every search's first expansion budget set to ``budget``."""
    state = initial_state(problem, PlannerConfig(algorithm=algorithm, max_time=30, seed=0))
    state.search_budget = budget
    if algorithm == "incremental":
        return solve_incremental(state)
    if algorithm == "focused":
        return solve_focused(state)
    return solve_with_skeletons(state, adaptive=algorithm == "adaptive")


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_searches_that_run_out_of_budget_do_not_lose_plans(algorithm: str) -> None:
    # A budget of one expansion cuts every search at first; doubling it must still find
    # (and never declare infeasible) the plan.
    problem = load_problem(EXAMPLES / "tamp2d_blocked.yaml")
    result = run_with_budget(problem, algorithm, budget=1)
    assert result.status == "solved"
    assert validate_plan(problem, result, check_stream_domains=False).valid


# Only one token can be somewhere: the goal (both a and c marked) is reachable under the
# delete relaxation but not really, so only an exhausted search may call it infeasible.
TOKEN_DOMAIN = """
(define (domain token)
  (:predicates (At ?x) (Link ?x ?y))
  (:action go
    :parameters (?x ?y)
    :precondition (and (At ?x) (Link ?x ?y))
    :effect (and (At ?y) (not (At ?x)))))
"""


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_budgeted_searches_still_prove_infeasibility(make_problem: MakeProblem,
                                                     algorithm: str) -> None:
    problem = load_problem(make_problem(TOKEN_DOMAIN, (
        "domain: dom\nobjects: {a: null, b: null, c: null, d: null}\n"
        'init: ["(At a)", "(Link a b)", "(Link b c)", "(Link c d)", "(Link d a)"]\n'
        "goal: (and (At a) (At c))\n")))
    result = run_with_budget(problem, algorithm, budget=1)
    assert result.status == "infeasible"
    assert result.stats["searches"] >= 2  # the first, cut-off search proved nothing


# A corridor s <-> a <-> b where every room also opens onto a pit with no way out. The goal
# asks to be in s and b at once: the delete relaxation thinks that reachable, so a greedy
# search is exhaustive and pops every pit state.
PIT_DOMAIN = """
(define (domain pits)
  (:predicates (At ?x) (Door ?x ?y))
  (:action go
    :parameters (?x ?y)
    :precondition (and (At ?x) (Door ?x ?y))
    :effect (and (At ?y) (not (At ?x)))))
"""


def test_greedy_search_skips_the_heuristic_in_dead_ends(
        make_problem: MakeProblem, monkeypatch: pytest.MonkeyPatch) -> None:
    from ltamp_cli.planner.search.heuristic import FFHeuristic

    rooms = ("s", "a", "b")
    doors = [("s", "a"), ("a", "s"), ("a", "b"), ("b", "a"), *((r, f"pit-{r}") for r in rooms)]
    objects = ", ".join(f"{o}: null" for o in (*rooms, *(f"pit-{r}" for r in rooms)))
    init = ", ".join(['"(At s)"', *(f'"(Door {x} {y})"' for x, y in doors)])
    problem = load_problem(make_problem(
        PIT_DOMAIN, f"domain: dom\nobjects: {{{objects}}}\ninit: [{init}]\n"
        "goal: (and (At s) (At b))\n"))
    evaluated: list[set[tuple[str, ...]]] = []
    original = FFHeuristic._evaluate

    def spy(self: FFHeuristic, vector):  # type: ignore[no-untyped-def]
        evaluated.append({self.task.facts[i] for i in vector.nonzero()[0]})
        return original(self, vector)

    monkeypatch.setattr(FFHeuristic, "_evaluate", spy)
    result = discrete(problem, algorithm="lazy-greedy")
    assert not result.solved and result.outcome is not None and not result.capped
    at = [{f[1] for f in facts if f[0].lower() == "at"} for facts in evaluated]
    assert {"s", "a", "b"} <= set().union(*at)  # the search did evaluate the corridor...
    assert not any(room.startswith("pit") for rooms_at in at for room in rooms_at)  # ...no pit
    assert result.outcome.evaluated >= 6  # the pits still count as visited states


def test_cost_bounded_join_keeps_exactly_the_bindings_within_the_bound() -> None:
    index = FactIndex()
    for fact in [("Conf", "a"), ("Conf", "b")]:
        index.add(fact)
    since = index.sizes()
    for fact in [("Conf", "#q1"), ("Conf", "#q2"), ("Conf", "#q3")]:
        index.add(fact)
    literals = [LiftedLiteral("Conf", ("?x",)), LiftedLiteral("Conf", ("?y",))]
    variables = ("?x", "?y")
    levels = {"#q1": 1, "#q2": 1, "#q3": 2}
    everything = join_tuples(literals, index, variables, since)
    for budget in range(5):
        bound = CostBound(levels, budget)
        kept = join_tuples(literals, index, variables, since, bound)
        within = [t for t in everything if sum(levels.get(v, 0) for v in t) <= budget]
        assert kept == within  # the same bindings in the same order
        assert bound.exceeded == (len(within) < len(everything))
    # Over the budget but with no complete binding: nothing is reported exceeded.
    lonely = CostBound(levels, 0)
    edge = [LiftedLiteral("Conf", ("?x",)), LiftedLiteral("Edge", ("?x", "?y"))]
    assert join_tuples(edge, index, variables, since, lonely) == []
    assert not lonely.exceeded
