"""PDDLStream's problem and solution types and its formula helpers, as plain tuples.

Formulas are tuples as in PDDLStream: ``("and", f1, f2)``, ``("not", f)``,
``("exists", ("?x", ...), f)``, a fact ``("AtPose", block, pose)`` whose arguments are
Python values, and strings starting with ``?`` are variables.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from ltamp_cli.errors import InputError
from ltamp_cli.planner.streams import WildOutput as PlannerWildOutput

FactTuple = tuple[Any, ...]
Formula = tuple[Any, ...]


class PDDLText(str):
    """PDDL text that remembers the file it was read from (for ``file:line:col`` errors)."""

    path: str

    def __new__(cls, text: str, path: str) -> PDDLText:
        made = super().__new__(cls, text)
        made.path = path
        return made


def read(path: str | Path) -> PDDLText:
    """The text of a PDDL file (PDDLStream's ``read``), remembering its path."""
    return PDDLText(Path(path).read_text(), str(path))


def get_file_path(file: str, relative: str) -> str:
    """``relative`` next to the file ``file`` (PDDLStream's ``get_file_path``)."""
    return str(Path(file).resolve().parent / relative)


class PDDLProblem(NamedTuple):
    """A PDDLStream problem: domain text, constant values, stream text, stream bindings,
    initial facts and goal formula (tuples of Python values)."""

    domain_pddl: str
    constant_map: Mapping[str, Any]
    stream_pddl: str | Sequence[str] | None
    stream_map: Mapping[str, Callable[..., Any]]
    init: Iterable[FactTuple]
    goal: Formula


class Action(NamedTuple):
    """One plan step: the action's name and its arguments' Python values."""

    name: str
    args: tuple[Any, ...]


class Certificate(NamedTuple):
    """``all_facts``: every fact known at the end; ``preimage_facts``: those the plan
    relies on. Facts are tuples ``(predicate, value, ...)``."""

    all_facts: list[Fact]
    preimage_facts: list[Fact]


class Solution(NamedTuple):
    """``plan`` (``None`` when not solved), its ``cost`` (``inf`` when not solved) and its
    :class:`Certificate`."""

    plan: list[Action] | None
    cost: float
    certificate: Certificate


def And(*formulas: Any) -> Formula:  # PDDLStream's names: capitalised
    return ("and", *formulas)


def Or(*formulas: Any) -> Formula:
    return ("or", *formulas)


def Not(formula: Any) -> Formula:
    return ("not", formula)


def Imply(condition: Any, consequence: Any) -> Formula:
    return ("imply", condition, consequence)


def Equal(left: Any, right: Any) -> Formula:
    return ("=", left, right)


def Exists(parameters: Sequence[str], formula: Any) -> Formula:
    """``parameters``: variable names such as ``["?c"]``."""
    return ("exists", tuple(parameters), formula)


def ForAll(parameters: Sequence[str], formula: Any) -> Formula:
    return ("forall", tuple(parameters), formula)


def WildOutput(values: Iterable[Any] = (), facts: Iterable[FactTuple] = (),
               actions: Iterable[Any] = (), enumerated: bool = False,
               replan: bool = False) -> PlannerWildOutput:
    """What one call of a stream yields (PDDLStream's ``WildOutput``): a list of output
    ``values`` plus ``facts`` it certifies beyond its ``:certified`` ones; ``enumerated``:
    nothing more for these inputs. ``actions`` are not supported; ``replan`` is ignored."""
    if list(actions):
        raise InputError("WildOutput(actions=...) is not supported")
    return PlannerWildOutput(tuple(tuple(v) for v in values), tuple(tuple(f) for f in facts),
                             enumerated)


def Fact(predicate: str, args: Iterable[Any]) -> Fact:
    """``(predicate, *args)``."""
    return (predicate, *args)


class PartialInputs(NamedTuple):
    """PDDLStream's optimistic-output policy for ``StreamInfo(opt_gen_fn=...)``: which
    inputs a stream's optimistic placeholders depend on (``""``: one shared by all
    instances; ``unique``: one per instance), as :class:`ltamp_cli.planner.streams.
    PartialInputs`. ``test`` is accepted and ignored."""

    inputs: str = ""
    unique: bool = False
    test: Callable[..., Any] | None = None


def Output(*values: Any) -> tuple[Any, ...]:
    """One output tuple of a stream (PDDLStream's ``Output``)."""
    return values


# PDDLStream's names for formula heads and plan statuses (its ``language.constants``).
EQ = "="
AND = "and"
OR = "or"
NOT = "not"
EXISTS = "exists"
FORALL = "forall"
WHEN = "when"
IMPLY = "imply"
MINIMIZE = "minimize"
MAXIMIZE = "maximize"
INCREASE = "increase"
PARAMETER = "?"
TYPE = "-"
TOTAL_COST = "total-cost"
TOTAL_TIME = "total-time"
FAILED = None  # a plan that is not one: no answer ...
INFEASIBLE = False  # ... or proven infeasible


def get_prefix(expression: Sequence[Any]) -> Any:
    """The head of a fact or formula tuple: ``get_prefix(("On", a, b)) == "On"``."""
    return expression[0]


def get_args(expression: Sequence[Any]) -> tuple[Any, ...]:
    """The arguments of a fact or formula tuple."""
    return tuple(expression[1:])


def is_plan(plan: Any) -> bool:
    """Whether ``plan`` is a plan (an empty one included), not ``FAILED`` / ``INFEASIBLE``."""
    return plan is not FAILED and plan is not INFEASIBLE


def get_length(plan: Any) -> float:
    """The number of steps of a plan; ``inf`` when there is none."""
    return len(plan) if is_plan(plan) else float("inf")


def str_from_plan(plan: Any) -> str:
    """A plan as ``[name(arg, ...), ...]``, or ``str(plan)`` when there is none."""
    if not is_plan(plan):
        return str(plan)
    return "[" + ", ".join(f"{name}({', '.join(map(str, args))})" for name, args in plan) + "]"


def partition_facts(facts: Iterable[Sequence[Any]]
                    ) -> tuple[list[Any], list[Any], list[Any]]:
    """``(positive facts, negated facts, function terms)``: ``("not", f)`` puts ``f`` in the
    second list, ``("=", term, value)`` and ``("minimize", term)`` put ``term`` in the third."""
    positive: list[Any] = []
    negated: list[Any] = []
    functions: list[Any] = []
    for fact in facts:
        head = fact[0]
        if head in (EQ, MINIMIZE):
            functions.append(fact[1])
        elif head == NOT:
            negated.append(fact[1])
        else:
            positive.append(fact)
    return positive, negated, functions


def read_pddl_pair(file: str, relative_dir: str = "./") -> list[PDDLText]:
    """``[domain.pddl, problem.pddl]`` read from the folder of the file ``file`` (a script's
    ``__file__``), plus ``relative_dir``."""
    folder = Path(file).resolve().parent / relative_dir
    return [read(folder / name) for name in ("domain.pddl", "problem.pddl")]


def read_pddlstream_pair(file: str, relative_dir: str = "./") -> list[PDDLText]:
    """``[domain.pddl, stream.pddl]`` read as :func:`read_pddl_pair` does."""
    folder = Path(file).resolve().parent / relative_dir
    return [read(folder / name) for name in ("domain.pddl", "stream.pddl")]


WILD = "*"
# ``stream_map=DEBUG``: every stream yields one new placeholder value per input tuple;
# ``SHARED_DEBUG``: one placeholder per stream and output, whatever the inputs.
DEBUG = "debug"
SHARED_DEBUG = "shared_debug"


GOAL_INDEX = -1  # an ``OrderedSkeleton`` order ``(i, GOAL_INDEX)``: step i done at the end


class OrderedSkeleton(NamedTuple):
    """A skeleton whose steps are partially ordered: ``actions`` is a list of ``(name,
    args)``, ``orders`` a set of ``(i, j)`` (step i before step j; ``j = GOAL_INDEX``: step i
    must be done when the plan ends)."""

    actions: Sequence[tuple[str, Sequence[Any]]]
    orders: frozenset[tuple[int, int]] | set[tuple[int, int]]


def linear_order(actions: Sequence[Any]) -> set[tuple[int, int]]:
    """The orders of a skeleton given as a list: in sequence, the last step at the end."""
    count = len(actions)
    return {(i, i + 1) for i in range(count - 1)} | ({(count - 1, GOAL_INDEX)} if count else set())


class PlanConstraints:
    """PDDLStream's plan constraints. ``skeletons``: ``None`` (no constraint) or a list of
    skeletons, each a list of ``(action name, args)`` (or an :class:`OrderedSkeleton`); an
    arg is a value (that object), a ``'?variable'`` (the same object wherever the skeleton
    names it), :data:`WILD` (any object) or a key of ``groups`` (one of its values). The
    plan completes one of the skeletons. ``exact``: the plan is made of skeleton steps only
    (else other actions may come anywhere between them); ``max_cost``: only plans cheaper
    than this. ``hint`` is accepted and, as in PDDLStream, has no effect."""

    def __init__(self, skeletons: Sequence[Any] | None = None,
                 groups: Mapping[Any, Sequence[Any]] | None = None, exact: bool = True,
                 hint: bool = False, max_cost: float = float("inf")) -> None:
        if skeletons is not None:
            skeletons = [s if isinstance(s, OrderedSkeleton)
                         else OrderedSkeleton(list(s), linear_order(list(s))) for s in skeletons]
        self.skeletons: list[OrderedSkeleton] | None = skeletons
        self.groups: dict[Any, list[Any]] = {k: list(v) for k, v in (groups or {}).items()}
        self.exact = exact
        self.hint = hint
        self.max_cost = max_cost

    def dump(self) -> None:
        print(f"PlanConstraints(exact={self.exact}, max_cost={self.max_cost})")
        for index, skeleton in enumerate(self.skeletons or ()):
            print(index, str_from_plan(skeleton.actions))

    def __repr__(self) -> str:
        return (f"PlanConstraints(skeletons={self.skeletons!r}, groups={self.groups!r}, "
                f"exact={self.exact!r}, hint={self.hint!r}, max_cost={self.max_cost!r})")


def print_solution(solution: Solution) -> None:
    """Print a solution's plan and cost, one action per line."""
    plan, cost, _ = solution
    if plan is None:
        print("Solved: False")
        return
    print(f"Solved: True\nCost: {cost:.3f}\nLength: {len(plan)}")
    for index, action in enumerate(plan, start=1):
        print(f"{index}) {action.name} {' '.join(map(str, action.args))}")


__all__ = ["AND", "DEBUG", "EQ", "EXISTS", "FAILED", "FORALL", "GOAL_INDEX", "IMPLY",
           "INCREASE", "INFEASIBLE", "MAXIMIZE", "MINIMIZE", "NOT", "OR", "PARAMETER",
           "SHARED_DEBUG", "TOTAL_COST", "TOTAL_TIME", "TYPE", "WHEN", "WILD", "Action", "And",
           "Certificate", "Equal", "Exists", "Fact", "ForAll", "Imply", "Not", "Or",
           "OrderedSkeleton", "Output", "PDDLProblem", "PDDLText", "PartialInputs",
           "PlanConstraints", "Solution", "WildOutput", "get_args", "get_file_path",
           "get_length", "get_prefix", "is_plan", "linear_order", "partition_facts",
           "print_solution", "read", "read_pddl_pair", "read_pddlstream_pair", "str_from_plan"]
