"""ltamp_cli.pddlstream runs PDDLStream-style problems: the stream language, wild and
exogenous streams, :fluents, domain constructs, and plans that carry the user's values."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from pddlstream_problems import (
    cut_problem,
    lamps_problem,
    lookout_problem,
    map_problem,
    reach_problem,
    roadmap_problem,
    sampler_problem,
    shelf_problem,
    write,
)

from ltamp_cli.pddlstream import (
    DEBUG,
    WILD,
    InputError,
    PDDLProblem,
    PlanConstraints,
    Solution,
    from_fn,
    solve,
    solve_from_pddl,
)
from ltamp_cli.pddlstream.problem import to_planning_problem
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve as plan
from ltamp_cli.planner.validate import validate_plan

ALGORITHMS = ("adaptive", "binding", "focused", "incremental")
MAX_TIME = 30.0


def run(problem: PDDLProblem, algorithm: str, **options: object) -> Solution:
    return solve(problem, algorithm=algorithm, max_time=MAX_TIME, verbose=False, **options)


def names(solution: Solution) -> list[str]:
    assert solution.plan is not None
    return [action.name for action in solution.plan]


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_rules_stream_only_predicates_and_user_values(tmp_path: Path, algorithm: str) -> None:
    """A :rule certifies the fact ``pick`` needs; predicates used only in the stream file or
    ``init`` are accepted; an undeclared, unbound :function is ignored; names match in any
    case; plan steps carry the very objects of ``init`` (unhashable dicts, numpy arrays)."""
    problem, items = reach_problem(tmp_path)
    solution = run(problem, algorithm)
    assert names(solution).count("pick") == 2 and names(solution)[0] == "move"
    picked = [action.args[0] for action in solution.plan if action.name == "pick"]
    assert {id(item) for item in picked} == {id(item) for item in items}
    for action in solution.plan:
        if action.name == "pick":
            item, pose, conf = action.args
            assert pose is item["pose"]
            np.testing.assert_allclose(conf, item["pose"] + [0.0, 1.0])
    # Costs: two moves (arm distances, from the :function binding) plus two picks.
    moves = [a for a in solution.plan if a.name == "move"]
    expected = 2 + sum(float(np.linalg.norm(a.args[0] - a.args[1])) for a in moves)
    assert solution.cost == pytest.approx(expected)
    assert ("reachable", moves[0].args[1]) in [
        (f[0], f[1]) for f in solution.certificate.all_facts if f[0] == "reachable"]


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_exogenous_stream_domain_is_solved_not_infeasible(tmp_path: Path,
                                                          algorithm: str) -> None:
    """The stream's :domain fact (Visible spot) is made true by an action: every algorithm
    finds the plan, and the output is used only after the fact holds."""
    solution = run(lookout_problem(tmp_path), algorithm)
    steps = names(solution)
    assert steps == ["walk", "clear-fog", "shoot"], steps
    assert solution.plan[2].args[0] == (3, 4)
    assert solution.plan[2].args[1].shape == (3,)


def test_exogenous_fact_that_never_holds_gives_no_plan(tmp_path: Path) -> None:
    """Without the action that makes (Visible spot) true, the stream's output is unusable:
    no plan may use it (the correct answer is that there is none)."""
    problem = lookout_problem(tmp_path)
    domain = problem.domain_pddl.replace("(:action clear-fog", "(:action clear-fog-never")
    domain = domain.replace("(and (Spot ?s) (At ?s))", "(and (Spot ?s) (At ?s) (Never))")
    domain = domain.replace("(Conf ?s))", "(Conf ?s) (Never))")
    solution = run(problem._replace(domain_pddl=domain), "adaptive")
    assert solution.plan is None


@pytest.mark.parametrize("algorithm", ["adaptive", "binding", "focused"])
def test_fluent_streams_see_the_state(tmp_path: Path, algorithm: str) -> None:
    solution = run(shelf_problem(tmp_path), algorithm)
    assert [(a.name, a.args[0]) for a in solution.plan] == [("clear", "b"), ("take", "a")]
    assert solution.plan[1].args[1] == ("path", "a", ())


def test_incremental_refuses_fluent_streams_at_their_declaration(tmp_path: Path) -> None:
    with pytest.raises(InputError) as caught:
        run(shelf_problem(tmp_path), "incremental")
    text = str(caught.value)
    assert "\n" not in text
    assert text.startswith(f"{tmp_path / 'stream.pddl'}:4:5: "), text
    assert ":fluents" in text and "adaptive" in text


@pytest.mark.parametrize("algorithm", ALGORITHMS)
@pytest.mark.parametrize("eager", [True, False])
def test_wild_facts_of_a_test_stream_open_the_way(tmp_path: Path, algorithm: str,
                                                  eager: bool) -> None:
    """A stream without :certified facts only yields wild facts: it is evaluated eagerly
    whether or not its StreamInfo says so (no optimistic plan could call it)."""
    problem, info = map_problem(tmp_path, eager=eager)
    solution = run(problem, algorithm, stream_info=info)
    assert [a.args for a in solution.plan] == [("hall", "kitchen"), ("kitchen", "garden")]


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_wild_facts_come_with_generator_outputs(tmp_path: Path, algorithm: str) -> None:
    """The goal needs a fact only wild outputs certify: optimistic plans cannot foresee it,
    so before answering "infeasible" the optimistic algorithms call the uncalled instances
    once, see wild facts and let the incremental algorithm finish."""
    solution = run(cut_problem(tmp_path), algorithm)
    assert names(solution) == ["saw", "mount"]
    assert solution.plan[1].args == (("oak", 3),)
    assert ("length", ("oak", 3), 3) in solution.certificate.all_facts


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_no_wrong_infeasible_when_only_wild_facts_lead_to_the_goal(tmp_path: Path,
                                                                   algorithm: str) -> None:
    """No optimistic plan exists (edges are wild facts of sampled configurations): the
    optimistic algorithms' failure proves nothing, and calling every stream finds the plan."""
    solution = run(roadmap_problem(tmp_path), algorithm)
    assert [a.args for a in solution.plan] == [(0.0, 2.5)]


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_domain_constructs(tmp_path: Path, algorithm: str) -> None:
    """constants (bound by constant_map), forall/exists/imply/or, conditional effects,
    derived predicates and action costs from a :function."""
    solution = run(lamps_problem(tmp_path), algorithm)
    steps = [(a.name, *a.args) for a in solution.plan]
    assert ("press", "MAIN") in steps and ("boost", "l1") in steps
    assert steps.index(("press", "MAIN")) < steps.index(("boost", "l1"))
    assert any(step[0] == "repair" and step[1] == "l2" for step in steps)
    assert solution.cost == pytest.approx(1 + 5 + 2.5 + (1 if ("press", "aux") in steps
                                                          else 0))


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_sampler_and_list_fn(tmp_path: Path, algorithm: str) -> None:
    solution = run(sampler_problem(tmp_path), algorithm)
    assert names(solution) == ["grab", "put"]
    grasp = solution.plan[0].args[1]
    assert isinstance(grasp, np.ndarray) and np.all(np.abs(grasp) <= 1)
    assert solution.plan[1].args == ("mug", grasp, 20.0)


def test_missing_binding_is_reported_at_the_declaration(tmp_path: Path) -> None:
    problem, _ = reach_problem(tmp_path)
    stream_map = {k: v for k, v in problem.stream_map.items() if k != "Distance"}
    with pytest.raises(InputError) as caught:
        run(problem._replace(stream_map=stream_map), "adaptive")
    text = str(caught.value)
    assert re.match(rf"{re.escape(str(tmp_path / 'stream.pddl'))}:6:3: function 'distance' "
                    "has no Python binding", text), text


def test_bindings_differing_only_in_case_are_refused(tmp_path: Path) -> None:
    problem, _ = reach_problem(tmp_path)
    stream_map = {**problem.stream_map, "DISTANCE": lambda a, b: 0.0}
    with pytest.raises(InputError, match="case-insensitive"):
        run(problem._replace(stream_map=stream_map), "adaptive")


@pytest.mark.parametrize(("edit", "fragment"), [
    (lambda p: p._replace(init=[*p.init, "Conf"]), "init[10]: expected a tuple"),
    (lambda p: p._replace(goal=("Holding",)), "predicate 'holding' takes 1 argument"),
    (lambda p: p._replace(goal=("Flying", 1)), "unknown predicate 'flying' in the goal"),
])
def test_bad_init_and_goal_are_one_line_errors(tmp_path: Path, edit: object,
                                                fragment: str) -> None:
    problem, _ = reach_problem(tmp_path)
    with pytest.raises(InputError) as caught:
        run(edit(problem), "adaptive")  # type: ignore[operator]
    assert fragment in str(caught.value) and "\n" not in str(caught.value)


def test_stream_only_predicate_with_two_arities_is_refused(tmp_path: Path) -> None:
    problem, _ = reach_problem(tmp_path)
    streams = problem.stream_pddl.replace("(:rule :inputs (?q) :domain (InWorkspace ?q)",
                                          "(:rule :inputs (?q) :domain (InWorkspace ?q ?q)")
    stream_text = write(tmp_path, "stream.pddl", streams)
    with pytest.raises(InputError) as caught:
        run(problem._replace(stream_pddl=stream_text), "adaptive")
    assert str(caught.value).startswith(f"{tmp_path / 'stream.pddl'}:5:")
    assert "predicate 'inworkspace' takes 1 argument(s) where it is first used" in str(
        caught.value)


def test_debug_stream_map_plans_with_placeholders(tmp_path: Path) -> None:
    problem, _ = reach_problem(tmp_path)
    solution = run(problem._replace(stream_map=DEBUG), "adaptive")
    assert names(solution).count("pick") == 2
    assert "inverse-kinematics" in repr(solution.plan[-1].args[-1])


def test_skeleton_constraints(tmp_path: Path) -> None:
    """A skeleton forces picking the box first."""
    problem, items = reach_problem(tmp_path)
    skeleton = [("move", [WILD, "?q1"]), ("pick", [items[1], WILD, "?q1"]),
                ("move", ["?q1", "?q2"]), ("pick", [items[0], WILD, "?q2"])]
    solution = run(problem, "adaptive", constraints=PlanConstraints(skeletons=[skeleton]))
    assert [a.args[0]["name"] for a in solution.plan if a.name == "pick"] == ["box", "cup"]


def test_solve_from_pddl() -> None:
    domain = """(define (domain toggle) (:predicates (On ?x) (Off ?x))
      (:action flip :parameters (?x) :precondition (Off ?x)
        :effect (and (On ?x) (not (Off ?x)))))"""
    problem = """(define (problem p) (:domain toggle) (:objects a b)
      (:init (Off a) (Off b)) (:goal (and (On a) (On b))))"""
    plan, cost = solve_from_pddl(domain, problem, unit_costs=True)
    assert plan is not None and sorted(a.args for a in plan) == [("a",), ("b",)]
    assert cost == 2


def test_unsolvable_problem_reports_no_plan(tmp_path: Path) -> None:
    """A stream that never yields anything: no plan, infinite cost (PDDLStream's Solution)."""
    problem, _ = reach_problem(tmp_path)
    stream_map = {**problem.stream_map, "inverse-KINEMATICS": from_fn(lambda i, p: None)}
    solution = run(problem._replace(stream_map=stream_map), "incremental")
    assert solution.plan is None and solution.cost == float("inf")


@pytest.mark.parametrize("build", [
    lambda folder: reach_problem(folder)[0], lookout_problem, shelf_problem,
    lambda folder: map_problem(folder, eager=False)[0], cut_problem, lamps_problem,
    sampler_problem, roadmap_problem,
], ids=["rule", "exogenous", "fluents", "wild-test", "wild-outputs", "adl", "samplers",
        "wild-roadmap"])
def test_independent_validator_accepts_the_plans(tmp_path: Path, build: object) -> None:
    """The planner's own validator replays each plan: rules are always true, wild facts are
    trusted as their call's results, everything else is re-derived."""
    problem = to_planning_problem(build(tmp_path))  # type: ignore[operator]
    result = plan(problem, PlannerConfig(algorithm="adaptive", max_time=MAX_TIME))
    assert result.solved
    report = validate_plan(problem, result)
    assert report.valid, report
