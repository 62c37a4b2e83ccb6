"""Faster search internals give the same answers (issue #19, kitchen_fluent speed).

* The FF heuristic's cost propagation (gathers for single-precondition operators and
  single-achiever facts, a padded matrix for the rest, see
  ``FFHeuristic._compile_layout``) gives the values and preferred operators of a plain
  Bellman-Ford h_add with first-cheapest-achiever supporters, written out here, on the
  states real solves evaluate and on random tasks with float costs, conditional effects,
  negated basic and derived conditions.
* A join step whose arguments are all bound is a membership test: joins equal brute-force
  enumeration on random fact sets with repeated variables and constants.
"""

from __future__ import annotations

import itertools
import random
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.planner.search import heuristic as heuristic_module
from ltamp_cli.planner.search.ground import (
    FactIndex,
    GroundAction,
    GroundAxiom,
    GroundEffect,
    Grounding,
    join,
    join_tuples,
)
from ltamp_cli.planner.search.heuristic import INFINITY, FFHeuristic, HeuristicResult
from ltamp_cli.planner.search.normalize import LiftedLiteral
from ltamp_cli.planner.search.task import TRUE_FACT, Task

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"


def reference_ff(heuristic: FFHeuristic, vector: np.ndarray) -> HeuristicResult:
    """h_FF over the heuristic's relaxed operators (``preconditions``, ``effects``,
    ``costs``, ``origin``), written plainly: Bellman-Ford rounds over lists until no fact
    gets cheaper, each fact's supporter the first of its achievers (by relaxed operator
    number) of minimal cost, the relaxed plan collected backwards from the goal."""
    task = heuristic.task
    if vector[task.goal]:
        return HeuristicResult(0.0, [])
    holds = [bool(v) for v in vector.tolist()] + [False] * (heuristic.num_facts
                                                            - task.num_facts)
    for source, negated in zip(heuristic.negated_sources.tolist(),
                               heuristic.negated_ids.tolist(), strict=True):
        holds[negated] = not vector[source]
    holds[TRUE_FACT] = True
    cost = [0.0 if h else INFINITY for h in holds]
    base = list(cost)
    achievers: dict[int, list[int]] = {}
    for op, adds in enumerate(heuristic.effects):
        for fact in adds:
            achievers.setdefault(fact, []).append(op)
    if not heuristic.preconditions or not achievers:
        return HeuristicResult(INFINITY, [])
    costs = heuristic.costs.tolist()

    def op_cost(op: int) -> float:
        total = 0.0
        for fact in heuristic.preconditions[op] or [TRUE_FACT]:
            total += cost[fact]
        return total + costs[op]

    while True:
        changed = False
        ops = [op_cost(op) for op in range(len(heuristic.preconditions))]
        for fact, achieving in achievers.items():
            cheapest = min(ops[op] for op in achieving)
            if cheapest < cost[fact]:
                cost[fact] = min(cheapest, base[fact])
                changed = True
        if not changed:
            break
    if cost[task.goal] == INFINITY:
        return HeuristicResult(INFINITY, [])
    supporter = {fact: next(op for op in achieving if ops[op] == min(ops[o] for o in achieving))
                 for fact, achieving in achievers.items()}
    chosen: set[int] = set()
    marked: set[int] = set()
    stack = [task.goal]
    while stack:
        fact = stack.pop()
        if fact in marked or cost[fact] == 0.0:
            continue
        marked.add(fact)
        op = supporter[fact]
        if op in chosen:
            continue
        chosen.add(op)
        stack.extend(heuristic.preconditions[op])
    value = float(sum(costs[i] for i in chosen))
    preferred = sorted({heuristic.origin[i] for i in chosen if heuristic.origin[i] >= 0
                        and all(cost[f] == 0.0 for f in heuristic.preconditions[i])})
    return HeuristicResult(value, preferred)


def random_task(rng: random.Random) -> tuple[Task, list[frozenset[int]]]:
    """A random grounded task (facts p0..p11 basic, d0..d2 derived, conditional effects,
    negative conditions, float costs) and a few random states of it."""
    basic = [("p", str(i)) for i in range(12)]
    derived = [("d", str(i)) for i in range(3)]
    actions = []
    for number in range(rng.randint(8, 30)):
        pre = tuple(rng.sample(basic + derived, rng.randint(0, 4)))
        pre_neg = tuple(f for f in rng.sample(basic + derived, rng.randint(0, 2))
                        if f not in pre)
        effects = []
        for fact in rng.sample(basic, rng.randint(1, 3)):
            condition = tuple(rng.sample(basic, rng.randint(0, 2))) if rng.random() < 0.3 else ()
            negative = tuple(rng.sample(basic, 1)) if rng.random() < 0.15 else ()
            effects.append(GroundEffect(condition, negative, fact, rng.random() < 0.7))
        actions.append(GroundAction(f"a{number}", (), pre, pre_neg, tuple(effects),
                                    round(rng.uniform(0.0, 3.0), 3)))
    axioms = [GroundAxiom(rng.choice(derived), tuple(rng.sample(basic, rng.randint(1, 3))),
                          tuple(rng.sample(basic, rng.randint(0, 1))))
              for _ in range(rng.randint(1, 6))]
    goal = tuple(rng.sample(basic + derived, rng.randint(1, 3)))
    axioms.append(GroundAxiom(("%goal",), goal, ()))
    reachable = set(basic) | set(derived) | {("%goal",)}
    grounding = Grounding(actions, axioms, reachable, frozenset(), frozenset({"d", "%goal"}))
    task = Task(grounding, set(rng.sample(basic, rng.randint(0, 5))))
    states = [task.init] + [
        frozenset(task.fact_ids[f] for f in rng.sample(basic, rng.randint(0, 6))
                  if f in task.fact_ids)
        for _ in range(4)]
    return task, states


@pytest.mark.parametrize("unit_costs,cost_bias", [(False, 1.0), (False, 0.0), (True, 1.0)])
def test_ff_layout_equals_plain_bellman_ford_on_random_tasks(unit_costs: bool,
                                                             cost_bias: float) -> None:
    rng = random.Random(0)
    compared = finite = 0
    for _ in range(150):
        task, states = random_task(rng)
        heuristic = FFHeuristic(task, cost_bias=cost_bias, unit_costs=unit_costs)
        for state in states:
            vector = task.state_vector(state)
            got, expected = heuristic._evaluate(vector), reference_ff(heuristic, vector)
            assert (got.value, got.preferred) == (expected.value, expected.preferred)
            compared += 1
            finite += expected.value not in (0.0, INFINITY)
    assert compared == 750 and finite > 200  # most states need a relaxed plan


def recorded_evaluations(monkeypatch: pytest.MonkeyPatch, example: str, algorithm: str,
                         seed: int) -> list[tuple[FFHeuristic, np.ndarray]]:
    """Solve ``example`` with its own planner options (``algorithm``, ``seed``) and return
    every FF evaluation made, as (heuristic, state vector) pairs."""
    recorded: list[tuple[FFHeuristic, np.ndarray]] = []
    original = FFHeuristic._evaluate

    def spy(self: FFHeuristic, vector: np.ndarray) -> HeuristicResult:
        recorded.append((self, vector.copy()))
        return original(self, vector)

    monkeypatch.setattr(heuristic_module.FFHeuristic, "_evaluate", spy)
    problem = load_problem(EXAMPLES / f"{example}.yaml")
    options = {k: v for k, v in problem.planner_options.items()
               if k in PlannerConfig.__dataclass_fields__}
    config = PlannerConfig(**{**options, "algorithm": algorithm, "seed": seed,
                              "max_time": 60.0, "statistics_dir": None})
    assert solve(problem, config).solved
    monkeypatch.setattr(heuristic_module.FFHeuristic, "_evaluate", original)
    return recorded


@pytest.mark.parametrize("example,algorithm", [("kitchen_fluent", "adaptive"),
                                               ("kitchen_symbolic", "adaptive"),
                                               ("tamp2d_uniform_tight_4", "binding")])
def test_ff_layout_equals_plain_bellman_ford_on_solved_examples(
        monkeypatch: pytest.MonkeyPatch, example: str, algorithm: str) -> None:
    recorded = recorded_evaluations(monkeypatch, example, algorithm, seed=1)
    assert len(recorded) >= 10
    for heuristic, vector in recorded[::3]:
        got, expected = heuristic._evaluate(vector), reference_ff(heuristic, vector)
        assert (got.value, got.preferred) == (expected.value, expected.preferred)


def brute_force(literals: list[LiftedLiteral], facts: set[tuple[str, ...]],
                values: list[str]) -> set[tuple[tuple[str, str], ...]]:
    variables = sorted({a for lit in literals for a in lit.args if a.startswith("?")})
    found = set()
    for assignment in itertools.product(values, repeat=len(variables)):
        binding = dict(zip(variables, assignment, strict=True))
        if all((lit.predicate, *(binding.get(a, a) for a in lit.args)) in facts
               for lit in literals):
            found.add(tuple(sorted(binding.items())))
    return found


def test_joins_with_fully_bound_steps_equal_brute_force() -> None:
    rng = random.Random(3)
    values = ["a", "b", "c"]
    terms = ["?x", "?y", "?z", "a"]
    nonempty = 0
    for _ in range(300):
        facts = {(p, *rng.choices(values, k=2)) for p in ("P", "Q", "R")
                 for _ in range(rng.randint(0, 6))}
        index = FactIndex()
        for fact in sorted(facts):
            index.add(fact)
        literals = [LiftedLiteral(rng.choice("PQR"), (rng.choice(terms), rng.choice(terms)))
                    for _ in range(rng.randint(1, 4))]
        expected = brute_force(literals, facts, values)
        got = {tuple(sorted(b.items())) for b in join(literals, index)}
        assert got == expected
        variables = tuple(sorted({a for lit in literals for a in lit.args
                                  if a.startswith("?")}))
        tuples = set(join_tuples(literals, index, variables))
        assert tuples == {tuple(v for _, v in b) for b in expected}
        nonempty += bool(expected)
    assert nonempty > 50


def reference_vector(task: Task, state: frozenset[int]) -> list[int]:
    """A state's truth values with its derived facts, by a plain fixpoint per stratum."""
    from ltamp_cli.planner.search.task import _stratify

    holds = [0] * task.num_facts
    holds[TRUE_FACT] = 1
    for fact in state:
        holds[fact] = 1
    strata = _stratify(task.axioms)
    for stratum in sorted(set(strata)):
        members = [i for i, s in enumerate(strata) if s == stratum]
        changed = True
        while changed:
            changed = False
            for i in members:
                head = task.axiom_heads[i]
                if not holds[head] and all(holds[f] for f in task.axiom_positive[i]) and not any(
                        holds[f] for f in task.axiom_negative[i]):
                    holds[head] = 1
                    changed = True
    return holds


def layered_task(rng: random.Random) -> tuple[Task, list[frozenset[int]]]:
    """A random task whose axioms form strata of each kind: one body literal of each sign
    (gathers), several (reduceat), recursive (a chain of derived facts) or not."""
    basic = [("p", str(i)) for i in range(10)]
    axioms = []
    for _ in range(rng.randint(1, 5)):  # stratum 0, recursive: a chain over reach/1
        a, b = rng.sample(range(6), 2)
        axioms.append(GroundAxiom(("reach", str(b)), (("reach", str(a)), rng.choice(basic)),
                                  ()))
    axioms.append(GroundAxiom(("reach", "0"), (rng.choice(basic),), ()))
    for i in range(rng.randint(1, 8)):  # stratum 1: one literal of each sign
        axioms.append(GroundAxiom(("s", str(i)), (rng.choice(basic),),
                                  (("reach", str(rng.randint(0, 5))),)
                                  if rng.random() < 0.7 else ()))
    for i in range(rng.randint(1, 4)):  # stratum 2: several literals of each sign
        axioms.append(GroundAxiom(("t", str(i)), tuple(rng.sample(basic, 2)),
                                  (("s", str(rng.randint(0, 7))), ("reach", str(i)))))
    axioms.append(GroundAxiom(("%goal",), (rng.choice(basic),), ()))
    actions = [GroundAction("a", (), (("reach", "3"),), (("t", "0"),),
                            (GroundEffect((), (), rng.choice(basic), True),), 1.0)]
    reachable = set(basic) | {a.head for a in axioms}
    grounding = Grounding(actions, axioms, reachable, frozenset(),
                          frozenset({"s", "reach", "t", "%goal"}))
    task = Task(grounding, set())
    states = [frozenset(task.fact_ids[f] for f in rng.sample(basic, rng.randint(0, 8))
                        if f in task.fact_ids) for _ in range(6)]
    return task, states


def test_state_vectors_equal_a_plain_fixpoint_per_stratum() -> None:
    rng = random.Random(5)
    kinds = set()
    derived_true = 0
    for _ in range(200):
        task, states = layered_task(rng)
        kinds.update((layer.recursive, layer.single_pos, layer.single_neg)
                     for layer in task.axiom_layers)
        for state in states:
            expected = reference_vector(task, state)
            assert task.state_vector(state).tolist() == expected
            derived_true += sum(expected[i] for i in range(task.num_facts)
                                if task.is_derived[i])
    assert {(True, False, True), (False, True, True), (False, False, False)} <= kinds
    assert derived_true > 500


def test_one_long_precondition_list_does_not_pad_every_operator() -> None:
    """A negated derived fact blocked by many rules gives one relaxed operator with hundreds
    of preconditions; the others (two each) must not be padded to its length (PDDLStream's
    discrete_belief: 4,200 preconditions padded 2,736 columns to 91 MB per search)."""
    basic = [("p", str(i)) for i in range(400)]
    long_action = GroundAction("long", (), tuple(basic), (), (GroundEffect((), (), ("g",), True),),
                               1.0)
    short = [GroundAction(f"s{i}", (), (basic[i], basic[i + 1]), (),
                          (GroundEffect((), (), basic[i + 2], True),), 1.0)
             for i in range(200)]
    goal = GroundAxiom(("%goal",), (("g",),), ())
    grounding = Grounding([long_action, *short], [goal], set(basic) | {("g",), ("%goal",)},
                          frozenset(), frozenset({"%goal"}))
    task = Task(grounding, {basic[0], basic[1]} | set(basic[202:]))
    heuristic = FFHeuristic(task, cost_bias=1.0, unit_costs=False)
    lengths = sum(len(p) for p in heuristic.preconditions if len(p) > 1)
    padded = sum(matrix.size for _, _, matrix in heuristic.multi_pre_blocks)
    assert lengths <= padded < 2 * lengths
    vector = task.state_vector(task.init)
    got, expected = heuristic._evaluate(vector), reference_ff(heuristic, vector)
    assert (got.value, got.preferred) == (expected.value, expected.preferred)
    assert 0.0 < got.value < INFINITY
