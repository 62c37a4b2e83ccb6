"""Fixtures for the planner tests: example problems, solved results, tiny domains on disk."""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from pathlib import Path

import pytest

from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import PlanningProblem, load_problem
from ltamp_cli.planner.result import PlanResult

EXAMPLES = Path(__file__).resolve().parents[2] / "problems" / "examples"
ALGORITHMS = ("adaptive", "binding", "focused", "incremental")


class Solved:
    """Loads each example once and caches one solve per (example, algorithm, seed)."""

    def __init__(self) -> None:
        self._problems: dict[str, PlanningProblem] = {}
        self._results: dict[tuple[str, str, int], PlanResult] = {}

    def problem(self, name: str) -> PlanningProblem:
        if name not in self._problems:
            self._problems[name] = load_problem(EXAMPLES / f"{name}.yaml")
        return self._problems[name]

    def result(self, name: str, algorithm: str, seed: int = 0,
               max_time: float = 60.0) -> PlanResult:
        key = (name, algorithm, seed)
        if key not in self._results:
            config = PlannerConfig(algorithm=algorithm, seed=seed, max_time=max_time)
            self._results[key] = solve(self.problem(name), config)
        return self._results[key]


@pytest.fixture(scope="session")
def solved() -> Solved:
    return Solved()


MakeProblem = Callable[..., Path]


@pytest.fixture
def make_problem(tmp_path: Path) -> MakeProblem:
    """Write a domain folder and a YAML problem into ``tmp_path``; returns the YAML path.

    ``domain``/``streams``/``bindings``/``problem`` are texts (dedented); ``streams`` and
    ``bindings`` are optional.
    """

    def make(domain: str, problem: str, streams: str | None = None,
             bindings: str | None = None, name: str = "problem.yaml") -> Path:
        folder = tmp_path / "dom"
        folder.mkdir(exist_ok=True)
        (folder / "domain.pddl").write_text(textwrap.dedent(domain).lstrip())
        if streams is not None:
            (folder / "stream.pddl").write_text(textwrap.dedent(streams).lstrip())
        if bindings is not None:
            (tmp_path / "bindings.py").write_text(textwrap.dedent(bindings).lstrip())
        path = tmp_path / name
        path.write_text(textwrap.dedent(problem).lstrip())
        return path

    return make
