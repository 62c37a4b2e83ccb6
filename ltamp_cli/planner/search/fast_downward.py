"""Optional discrete search with Fast Downward (the ``fd`` extra).

Only the *search* step is delegated: the task grounded and compiled by the planner
(:class:`~ltamp_cli.planner.search.task.Task`) is written as a propositional PDDL task —
fact ``i`` becomes the nullary predicate ``(f<i>)``, operator ``j`` the parameterless action
``op<j>``, ground axioms become ``:derived`` rules — so a plan maps back to operator indices
exactly, whatever characters the planner's object names contain. Fast Downward's translator
(package ``fast-downward-translate``) and its ``downward`` search binary (shipped inside the
``up-fast-downward`` wheel) run as subprocesses in a temporary directory, each with the time
left until the deadline as timeout. The returned :class:`SearchOutcome` carries the states
visited, recomputed with the task's own successor function, so plan preimages and action
elimination work as for the in-process engines.
"""

from __future__ import annotations

import importlib.util
import math
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from ltamp_cli.errors import InputError
from ltamp_cli.planner.search.engine import SearchOutcome, SearchTimeout
from ltamp_cli.planner.search.heuristic import INFINITY
from ltamp_cli.planner.search.postprocess import simulate
from ltamp_cli.planner.search.task import FALSE_FACT, TRUE_FACT, Task

MISSING_EXTRA = "--search fd needs the optional 'fd' extra: pip install ltamp[fd]"

# Search configurations by ``--search`` name. ``fd``: lazy greedy best-first on h_FF with
# preferred operators (the core of LAMA's first iteration, without landmarks, which do not
# support axioms); ``fd-wastar``: eager weighted A* (w = 2), like ``wastar``. h_FF counts
# each action's cost plus one (LAMA's ``plusone``, the in-process engine's ``cost_bias``):
# TAMP domains often have zero-cost actions, where plain h_FF is 0 on whole plateaus and the
# search goes blind. This Fast Downward applies a search's ``cost_type`` to g only, so the
# heuristic is wrapped in ``eval_modify_costs``.
_HEURISTIC = "eval_modify_costs(ff(), cost_type={cost})"
_SEARCHES = {
    "fd": "let(h, {heuristic}, lazy_greedy([h], preferred=[h]))",
    "fd-wastar": "let(h, {heuristic}, eager_wastar([h], preferred=[h], w=2, cost_type={cost}))",
}


def search_config(algorithm: str, unit_costs: bool) -> str:
    """The ``downward --search`` argument for ``algorithm`` (one of :data:`FD_SEARCHES`)."""
    cost = "one" if unit_costs else "plusone"
    return _SEARCHES[algorithm].format(heuristic=_HEURISTIC.format(cost=cost), cost=cost)


FD_SEARCHES = tuple(_SEARCHES)

# Fast Downward exit codes (driver/returncodes.py) that mean "no plan", not "failure".
NO_PLAN_CODES = frozenset({10, 11, 12})  # translate unsolvable, unsolvable, incomplete
OUT_OF_TIME_CODES = frozenset({21, 23, 24})
# Fast Downward needs integer costs: fractional costs are scaled and rounded.
COST_SCALE = 1000


@dataclass(frozen=True)
class FastDownward:
    """Where the two Fast Downward components are: the translator is run as
    ``python -m fast_downward.translate`` with ``python``, the search as ``downward``."""

    python: str
    downward: Path


def locate_fast_downward() -> FastDownward:
    """Find the translator module and the ``downward`` binary without importing them.

    ``up_fast_downward``'s ``__init__`` imports ``unified_planning``, which the project does
    not need, so only the package's location is looked up. Raises :class:`InputError` with
    the install hint when either package is missing.
    """
    try:
        translate = importlib.util.find_spec("fast_downward.translate")
    except ModuleNotFoundError:
        translate = None
    wheel = importlib.util.find_spec("up_fast_downward")
    if translate is None or wheel is None or not wheel.submodule_search_locations:
        raise InputError(MISSING_EXTRA)
    for folder in wheel.submodule_search_locations:
        binary = Path(folder) / "downward" / "builds" / "release" / "bin" / "downward"
        if binary.is_file():
            return FastDownward(sys.executable, binary)
    raise InputError(MISSING_EXTRA)


def _cost_scale(task: Task, unit_costs: bool) -> int:
    """1 when every operator cost is integral (or costs are ignored), else ``COST_SCALE``."""
    if unit_costs:
        return 1
    for index, op in enumerate(task.operators):
        if op.cost < 0 or not math.isfinite(op.cost):
            raise InputError(f"action {op.action} (operator {index}) has cost {op.cost:g}: "
                             "Fast Downward needs finite non-negative costs")
    if all(float(op.cost).is_integer() for op in task.operators):
        return 1
    return COST_SCALE


def _atom(fact: int) -> str:
    return f"(f{fact})"


def _conjunction(positive: Iterable[int], negative: Iterable[int]) -> str:
    parts = [_atom(f) for f in positive if f != TRUE_FACT]
    parts += [f"(not {_atom(f)})" for f in negative if f != FALSE_FACT]
    return "(and " + " ".join(parts) + ")"


def write_pddl(task: Task, unit_costs: bool = False) -> tuple[str, str, int]:
    """The task as propositional PDDL: ``(domain text, problem text, cost scale)``.

    Operator ``j`` costs ``round(cost_j * scale)`` (no costs at all with ``unit_costs``).
    Fact 0 (always true) is an initial fact nothing deletes; fact 1 is never true.
    """
    scale = _cost_scale(task, unit_costs)
    derived = {i for i in range(task.num_facts) if task.is_derived[i]}
    lines = ["(define (domain ltamp-grounded)",
             " (:requirements :strips :negative-preconditions :conditional-effects"
             " :derived-predicates" + ("" if unit_costs else " :action-costs") + ")",
             " (:predicates " + " ".join(_atom(i) for i in range(task.num_facts)) + ")"]
    if not unit_costs:
        lines.append(" (:functions (total-cost) - number)")
    for head, axiom in zip(task.axiom_heads, task.axioms, strict=True):
        negative = [task.fact_ids[f] for f in axiom.body_neg]
        body = _conjunction([task.fact_ids[f] for f in axiom.body_pos], negative)
        lines.append(f" (:derived {_atom(head)} {body})")
    for index, op in enumerate(task.operators):
        effects = [_atom(f) for f in op.adds] + [f"(not {_atom(f)})" for f in op.deletes]
        for effect in op.conditional:
            literal = _atom(effect.fact) if effect.positive else f"(not {_atom(effect.fact)})"
            condition = _conjunction(effect.condition_pos, effect.condition_neg)
            effects.append(f"(when {condition} {literal})")
        if not unit_costs:
            effects.append(f"(increase (total-cost) {round(op.cost * scale)})")
        lines.append(f" (:action op{index} :parameters ()"
                     f" :precondition {_conjunction(op.pre_pos, op.pre_neg)}"
                     f" :effect (and {' '.join(effects)}))")
    lines.append(")")
    init = [_atom(TRUE_FACT)] + [_atom(f) for f in sorted(task.init) if f not in derived]
    if not unit_costs:
        init.append("(= (total-cost) 0)")
    problem = ["(define (problem ltamp-task) (:domain ltamp-grounded)",
               " (:init " + " ".join(init) + ")",
               f" (:goal {_atom(task.goal)})"]
    if not unit_costs:
        problem.append(" (:metric minimize (total-cost))")
    problem.append(")")
    return "\n".join(lines) + "\n", "\n".join(problem) + "\n", scale


def parse_plan(text: str, num_operators: int) -> list[int]:
    """Operator indices of a Fast Downward plan file (``(op3)`` lines, ``;`` comments)."""
    plan = []
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith(";"):
            continue
        match = re.fullmatch(r"\(\s*op(\d+)\s*\)", line, flags=re.IGNORECASE)
        if match is None or int(match.group(1)) >= num_operators:
            raise RuntimeError(f"unexpected line in Fast Downward's plan: {line!r}")
        plan.append(int(match.group(1)))
    return plan


def _last_count(pattern: str, log: str) -> int:
    found = re.findall(pattern, log)
    return int(found[-1]) if found else 0


# subprocess waits with poll(), whose timeout is an int of milliseconds: ~24.8 days at most.
SUBPROCESS_TIMEOUT_MAX_S = (2**31 - 1) / 1000


def _run(command: list[str], workdir: Path, deadline: float, stdin_path: Path | None = None
         ) -> subprocess.CompletedProcess[str]:
    remaining: float | None = deadline - time.perf_counter()
    if remaining is not None and remaining <= 0:
        raise SearchTimeout
    if remaining is not None and remaining >= SUBPROCESS_TIMEOUT_MAX_S:
        remaining = None  # no limit (max_time=inf, 1e9): poll() overflows on such timeouts
    try:
        if stdin_path is None:
            return subprocess.run(command, cwd=workdir, capture_output=True, text=True,
                                  timeout=remaining, check=False,
                                  stdin=subprocess.DEVNULL)
        with stdin_path.open() as stdin:
            return subprocess.run(command, cwd=workdir, capture_output=True, text=True,
                                  timeout=remaining, check=False, stdin=stdin)
    except subprocess.TimeoutExpired as error:
        raise SearchTimeout from error


def _failure(stage: str, process: subprocess.CompletedProcess[str]) -> RuntimeError:
    tail = "\n".join((process.stdout + process.stderr).strip().splitlines()[-15:])
    return RuntimeError(f"Fast Downward's {stage} failed (exit code {process.returncode}):\n"
                        f"{tail}")


def search_with_fast_downward(task: Task, deadline: float, algorithm: str = "fd",
                              unit_costs: bool = False) -> SearchOutcome:
    """Solve ``task`` with Fast Downward before ``deadline`` (a ``time.perf_counter`` value).

    ``algorithm`` is a key of :data:`FD_SEARCHES`. Returns the plan as operator indices of
    ``task`` with its real cost (plan ``None``, cost ``inf`` when Fast Downward proves the
    task unsolvable or its search space is exhausted), Fast Downward's expanded/evaluated
    counts and the states visited (``len(plan) + 1``, starting at ``task.init``). Raises
    :class:`SearchTimeout` when the deadline passes, :class:`InputError` when the ``fd``
    extra is not installed.
    """
    if algorithm not in FD_SEARCHES:
        raise ValueError(f"unknown Fast Downward search {algorithm!r}; expected one of "
                         f"{', '.join(FD_SEARCHES)}")
    start = time.perf_counter()
    tools = locate_fast_downward()
    domain, problem, _ = write_pddl(task, unit_costs)
    with tempfile.TemporaryDirectory(prefix="ltamp-fd-") as folder:
        workdir = Path(folder)
        (workdir / "domain.pddl").write_text(domain)
        (workdir / "problem.pddl").write_text(problem)
        translated = _run([tools.python, "-m", "fast_downward.translate", "domain.pddl",
                           "problem.pddl", "--sas-file", "output.sas",
                           "--invariant-generation-max-candidates", "0"], workdir, deadline)
        if translated.returncode in OUT_OF_TIME_CODES:
            raise SearchTimeout
        if translated.returncode in NO_PLAN_CODES:
            return SearchOutcome(None, INFINITY, 0, 0, time.perf_counter() - start)
        if translated.returncode != 0:
            raise _failure("translator", translated)
        searched = _run([str(tools.downward), "--search", search_config(algorithm, unit_costs),
                         "--internal-plan-file", "plan"], workdir, deadline,
                        stdin_path=workdir / "output.sas")
        expanded = _last_count(r"Expanded (\d+) state", searched.stdout)
        evaluated = _last_count(r"Evaluated (\d+) state", searched.stdout)
        if searched.returncode in OUT_OF_TIME_CODES:
            raise SearchTimeout
        if searched.returncode in NO_PLAN_CODES:
            return SearchOutcome(None, INFINITY, expanded, evaluated,
                                 time.perf_counter() - start)
        plan_file = workdir / "plan"
        if searched.returncode != 0 or not plan_file.is_file():
            raise _failure("search", searched)
        plan = parse_plan(plan_file.read_text(), len(task.operators))
    kept, states, reaches_goal = simulate(task, plan, set())
    if len(kept) != len(plan) or not reaches_goal:
        raise RuntimeError("Fast Downward's plan does not solve the task it was given "
                           f"(applicable steps {len(kept)}/{len(plan)}, goal reached: "
                           f"{reaches_goal}); the PDDL export and the task disagree")
    cost = float(sum(task.operators[i].cost for i in plan))
    return SearchOutcome(plan, cost, expanded, evaluated, time.perf_counter() - start, states)
