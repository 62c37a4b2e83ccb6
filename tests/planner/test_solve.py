"""Planner results: every example × algorithm solved and validated, determinism, isolation
between runs, infeasible problems and time limits."""

from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from line_domain import LINE_BINDINGS, LINE_DOMAIN, LINE_STREAMS

from ltamp_cli.planner.algorithms.common import ALGORITHMS, PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import PlanningProblem, load_problem
from ltamp_cli.planner.result import PlanResult
from ltamp_cli.planner.validate import validate_plan

MakeProblem = Callable[..., Path]

FAST_EXAMPLES = ("blocksworld", "tamp2d_blocked", "tamp2d_4blocks", "synthetic_goodregion")
# kitchen_symbolic takes ~0.5 s to plan per algorithm now (see bench/planner.py; ~2-3 s
# with validation on a loaded machine), so it is no longer a slow test.
EXAMPLE_CASES = [(name, algorithm) for name in (*FAST_EXAMPLES, "kitchen_symbolic")
                 for algorithm in ALGORITHMS]


def signature(result: PlanResult) -> tuple[Any, ...]:
    """What must be identical between two runs with the same seed."""
    assert result.plan is not None
    return (result.status, round(result.cost, 9),
            tuple((s.name, s.args, repr(s.values), s.cost) for s in result.plan),
            tuple(result.certificate.stream_results))


@pytest.mark.parametrize(("name", "algorithm"), EXAMPLE_CASES)
def test_example_solved_and_validated(solved, name: str, algorithm: str  # type: ignore[no-untyped-def]
                                      ) -> None:
    result = solved.result(name, algorithm)
    assert result.status == "solved", result.stats
    report = validate_plan(solved.problem(name), result)
    assert report.valid, report.errors
    assert report.cost == pytest.approx(result.cost)
    assert result.stats["algorithm"] == algorithm
    assert result.stats["searches"] >= 1
    for step in result.plan:
        assert len(step.values) == len(step.args)
        assert not any(arg.startswith("#") for arg in step.args)  # no optimistic objects


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_certificate_is_closed_under_stream_domains(solved, algorithm: str  # type: ignore[no-untyped-def]
                                                    ) -> None:
    result = solved.result("tamp2d_blocked", algorithm)
    report = validate_plan(solved.problem("tamp2d_blocked"), result)
    assert report.valid, report.errors[:3]


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_same_seed_same_plan(algorithm: str) -> None:
    problem = load_problem(Path(__file__).resolve().parents[2] / "problems" / "examples"
                           / "tamp2d_blocked.yaml")
    config = PlannerConfig(algorithm=algorithm, seed=7, max_time=30)
    first, second = solve(problem, config), solve(problem, config)
    assert first.solved
    assert signature(first) == signature(second)
    assert first.objects.keys() == second.objects.keys()


def test_seed_changes_samples(solved) -> None:  # type: ignore[no-untyped-def]
    # Guards the determinism test against a planner that ignores the seed altogether.
    problem = solved.problem("tamp2d_blocked")
    values = set()
    for seed in range(4):
        result = solve(problem, PlannerConfig(algorithm="incremental", seed=seed, max_time=30))
        assert result.solved
        values.add(tuple(repr(s.values) for s in result.plan))
    assert len(values) > 1


def test_interleaved_planners_do_not_interfere(solved) -> None:  # type: ignore[no-untyped-def]
    jobs = [("tamp2d_blocked", "focused", 1), ("tamp2d_4blocks", "incremental", 2),
            ("blocksworld", "focused", 0)]
    alone = {job: signature(solve(solved.problem(job[0]),
                                  PlannerConfig(algorithm=job[1], seed=job[2], max_time=60)))
             for job in jobs}
    # Alternately in one thread...
    for job in (*jobs, *reversed(jobs)):
        result = solve(solved.problem(job[0]),
                       PlannerConfig(algorithm=job[1], seed=job[2], max_time=60))
        assert signature(result) == alone[job], job
    # ... and concurrently in threads (each planner has its own problem object too).
    found: dict[tuple[str, str, int], tuple[Any, ...]] = {}
    errors: list[BaseException] = []

    def run(job: tuple[str, str, int]) -> None:
        try:
            problem = load_problem(Path(solved.problem(job[0]).path))
            config = PlannerConfig(algorithm=job[1], seed=job[2], max_time=60)
            found[job] = signature(solve(problem, config))
        except BaseException as error:  # re-raised in the main thread
            errors.append(error)

    threads = [threading.Thread(target=run, args=(job,)) for job in jobs]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors, errors
    assert found == alone



def test_solve_restores_garbage_collector(solved, monkeypatch: pytest.MonkeyPatch  # type: ignore[no-untyped-def]
                                          ) -> None:
    # solve() switches automatic collection off while it runs (process-wide setting; the
    # waiting thread collects instead, see gc_pacing): overlapping solves in threads and a
    # solve that raises must all leave the collector as they found it.
    import gc

    from ltamp_cli.planner import api

    before = (gc.get_threshold(), gc.get_freeze_count(), gc.isenabled())
    seen: list[tuple[int, ...]] = []
    problem = solved.problem("blocksworld")

    def run(seed: int) -> None:
        result = solve(problem, PlannerConfig(algorithm="focused", seed=seed, max_time=60))
        seen.append(gc.get_threshold())
        assert result.solved

    threads = [threading.Thread(target=run, args=(seed,)) for seed in range(3)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(seen) == 3
    assert (gc.get_threshold(), gc.get_freeze_count(), gc.isenabled()) == before

    def fail(*args: object) -> None:
        assert not gc.isenabled()  # paced by the waiting thread while solving
        raise RuntimeError("boom")

    monkeypatch.setattr(api, "initial_state", fail)
    with pytest.raises(RuntimeError, match="boom"):
        solve(problem, PlannerConfig(algorithm="focused", seed=0, max_time=60))
    assert (gc.get_threshold(), gc.get_freeze_count(), gc.isenabled()) == before


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_solve_leaves_no_cyclic_garbage(solved, algorithm: str  # type: ignore[no-untyped-def]
                                        ) -> None:
    # Reference cycles (e.g. nested recursive functions closing over the task) keep a whole
    # planner state alive until the collector traverses it: tens of milliseconds per solve.
    import gc

    problem = solved.problem("tamp2d_4blocks")
    gc.collect()
    gc.disable()
    try:
        result = solve(problem, PlannerConfig(algorithm=algorithm, seed=1, max_time=60))
        assert result.solved
        del result
        assert gc.collect() == 0
    finally:
        gc.enable()


SYMBOLIC_DOMAIN = """
(define (domain d)
  (:predicates (P ?x) (Q ?x ?y))
  (:action go
    :parameters (?x ?y)
    :precondition (and (P ?x) (Q ?x ?y))
    :effect (and (P ?y) (not (P ?x)))))
"""


def line_problem(make_problem: MakeProblem, top: int | None, goal: int) -> PlanningProblem:
    text = (f"domain: dom\nbindings: bindings.py\nworld: {{top: {'null' if top is None else top}"
            f", goal: {goal}}}\nobjects: {{p0: 0}}\ninit: [\"(Pos p0)\", \"(At p0)\"]\n"
            "goal: (exists (?p) (and (At ?p) (Goal ?p)))\n")
    return load_problem(make_problem(LINE_DOMAIN, text, LINE_STREAMS, LINE_BINDINGS))


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_stream_problem_solved_and_validated(make_problem: MakeProblem, algorithm: str) -> None:
    problem = line_problem(make_problem, top=5, goal=3)
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=20))
    assert result.solved
    assert [s.values for s in result.plan] == [(0, 1), (1, 2), (2, 3)]
    report = validate_plan(problem, result)  # a chain: here the certificate is complete
    assert report.valid, report.errors


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_infeasible_symbolic(make_problem: MakeProblem, algorithm: str) -> None:
    problem = load_problem(make_problem(SYMBOLIC_DOMAIN, (
        "domain: dom\nobjects: {a: null, b: null, c: null}\n"
        "init: [\"(P a)\", \"(Q a b)\", \"(Q c a)\"]\ngoal: (P c)\n")))
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=20))
    assert result.status == "infeasible"
    assert result.plan is None


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_infeasible_when_streams_run_out(make_problem: MakeProblem, algorithm: str) -> None:
    problem = line_problem(make_problem, top=4, goal=9)
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=20))
    assert result.status == "infeasible"
    assert result.time_s < 20


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_time_limit_gives_timeout(make_problem: MakeProblem, algorithm: str) -> None:
    # Streams never run out and the goal value never comes: only the time limit stops it.
    problem = line_problem(make_problem, top=None, goal=-1)
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=0.5))
    assert result.status == "timeout"
    assert result.plan is None
    assert 0.5 <= result.time_s < 5.0


def test_tiny_time_limit_on_an_example(solved) -> None:  # type: ignore[no-untyped-def]
    result = solve(solved.problem("tamp2d_4blocks"),
                   PlannerConfig(algorithm="focused", max_time=1e-4))
    assert result.status == "timeout"
