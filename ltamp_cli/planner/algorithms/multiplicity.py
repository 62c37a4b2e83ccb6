"""Whether an optimistic algorithm's "infeasible" is proven despite one placeholder per
stream instance (issue: two distinct outputs of one generator instance).

The optimistic algorithms give each stream instance one placeholder output. A plan that
needs two *distinct* outputs of one instance (``go(?q)`` requires ``(not (Seen ?q))`` and
the goal needs two ``go``s) has no optimistic counterpart, so their failure alone proves
nothing. :func:`relaxed_goal_reachable` decides a relaxation in which merging objects
cannot hurt: no delete effects, no negative literals (preconditions, axiom bodies, goal),
no inequalities, effect conditions assumed true, and each stream's certified facts
asserted optimistically for an abstract output:

* every instance that is not exhausted (over objects that exist now or over abstract
  ones) certifies its facts for the stream's one abstract output tuple, and for every
  output tuple that some instance of the same stream made so far; an exhausted instance
  certifies nothing more (its real outputs are real facts already).

One abstract output per stream, not per instance: objects are values, so two instances
of a stream can make the same new value (``grasp(o1)`` and ``grasp(o2)`` both yield
``"side"`` on their second call: red-team round 8); with one abstract output each, the
facts both certify about it never met on one object and such a plan was called
"infeasible". Mapping every future output of a stream to that stream's abstract output is
a homomorphism that keeps positive facts, so every real plan, however many distinct
outputs it uses, maps to a relaxed plan here. When the goal is unreachable in this finite
relaxation, no plan exists and "infeasible" is proven; otherwise the caller must not claim
it yet: :func:`check_infeasibility` then searches the finer abstract task of
:mod:`.abstract_task`, which keeps deletes, negation and inequalities exact wherever only
known objects are concerned (merging touches only the stand-ins); unreachable there is a
proof too. Not covered (as in the optimistic algorithms): a future output that
equals an object made by *another* stream or given by the problem, or that repeats only
part of an earlier output tuple of its stream (objects are values), and facts a stream
does not declare (wild facts, handled by the caller). The caller
(:func:`.api._infeasibility_unproven`) does not ask for a proof when a stream has output an
object the problem gives or the goal names an object no initial fact mentions (red team
round 9: a grid's goal cell reached by a neighbour stream was "infeasible").
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from ltamp_cli.planner.algorithms.abstract_task import (
    Closure,
    Unrepresentable,
    budget_deadline,
    search_abstract_task,
)
from ltamp_cli.planner.algorithms.common import PlannerState, instantiate_atoms
from ltamp_cli.planner.pddl.syntax import (
    OBJECT_TYPE,
    ExternalPredicate,
    Stream,
    is_variable,
)
from ltamp_cli.planner.search.clock import SearchTimeout
from ltamp_cli.planner.search.ground import (
    Fact,
    FactIndex,
    RuleSet,
    _Rule,
    semi_naive_fixpoint,
)
from ltamp_cli.planner.search.normalize import GOAL_PREDICATE, NormalAction, NormalAxiom
from ltamp_cli.planner.search.solve import normalized_task

# Prefix of abstract outputs: no parsed PDDL name starts with it.
ABSTRACT_PREFIX = "#any:"


class UnsupportedConstruct(Exception):
    """The relaxation cannot represent a rule (an effect on a variable that no positive
    literal binds): the caller treats infeasibility as unproven."""


def has_generators(state: PlannerState) -> bool:
    """Whether some stream makes new objects (only then can multiplicity matter)."""
    return any(isinstance(e, Stream) and e.outputs for e in state.externals.values())


def relaxed_goal_reachable(state: PlannerState) -> bool:
    """Whether the goal is reachable in the relaxation of the module docstring, starting
    from the facts and objects known now (``state.facts``, ``state.object_types``).

    Raises :class:`~ltamp_cli.planner.search.engine.SearchTimeout` past the solve's deadline
    and :class:`UnsupportedConstruct` (both mean: not proven)."""
    return (GOAL_PREDICATE,) in relaxed_closure(state).index.members


def relaxed_closure(state: PlannerState) -> Closure:
    """Every fact the relaxation of the module docstring reaches (a fixpoint of the rules
    and the streams), with the rules normalised over the final objects (known ones and
    stand-ins): what :func:`.abstract_task.search_abstract_task` grounds."""
    problem = state.problem
    real = frozenset(state.object_types)
    objects: dict[str, str] = dict(state.object_types)
    index = FactIndex.of_sorted(sorted(state.facts.members), state.deadline)
    enumerated: dict[str, dict[str, int]] = {}
    made = _outputs_made(state)
    delta: list[Fact] | None = None
    rule_set: RuleSet | None = None
    renormalize = True
    known = set(state.facts.members)
    while True:
        if renormalize:
            # Quantifiers and forall effects expand over the objects: again when new
            # abstract objects came, then from scratch over every fact.
            actions, axioms, typed = normalized_task(
                problem.domain, objects, (), problem.goal, state.deadline)
            for fact in typed:
                index.add(fact)
                if fact[1] in real:
                    known.add(fact)
            rule_set = RuleSet(actions, axioms)
            delta, renormalize = None, False
        assert rule_set is not None
        semi_naive_fixpoint(rule_set, index, delta, _RelaxedEmit(index), state.deadline)
        before = len(objects)
        delta = _stream_round(state, index, real, objects, enumerated, made)
        if not delta:
            return Closure(actions, axioms, index, real, known, state.externals.values())
        renormalize = len(objects) != before


class _RelaxedEmit:
    """Record a rule instance of the relaxation: its positive effects (conditions assumed
    true) or its axiom head become reachable; negative literals and inequalities are
    ignored, equalities between bound terms are kept (merging keeps them true)."""

    def __init__(self, index: FactIndex) -> None:
        self.index = index

    def __call__(self, rule: _Rule, binding: dict[str, str], delta: list[Fact]) -> None:
        binding = dict(binding)
        for literal in rule.equalities:
            if not literal.positive:
                continue
            left, right = (binding.get(a, a) for a in literal.args)
            if is_variable(left) and is_variable(right):
                continue  # nothing binds them: an effect on them is unsupported (_bound)
            if is_variable(left):
                binding[left] = right
            elif is_variable(right):
                binding[right] = left
            elif left != right:
                return
        source = rule.source
        if isinstance(source, NormalAxiom):
            self._reach((source.predicate, *_bound(source.head_args, binding)), delta)
            return
        assert isinstance(source, NormalAction)
        for effect in source.effects:
            if effect.positive:
                self._reach((effect.predicate, *_bound(effect.args, binding)), delta)

    def _reach(self, fact: Fact, delta: list[Fact]) -> None:
        if self.index.add(fact):
            delta.append(fact)


def _bound(args: Iterable[str], binding: Mapping[str, str]) -> tuple[str, ...]:
    ground = tuple(binding.get(a, a) for a in args)
    if any(is_variable(a) for a in ground):
        raise UnsupportedConstruct(f"unbound variable in {ground}")
    return ground


def _outputs_made(state: PlannerState) -> dict[str, list[tuple[str, ...]]]:
    """Per stream, the output tuples its instances made so far (first made first)."""
    made: dict[str, dict[tuple[str, ...], None]] = {}
    for instance in list(state.instances.values()):
        if instance.results:
            made.setdefault(instance.name, {}).update(dict.fromkeys(instance.results))
    return {name: list(outputs) for name, outputs in made.items()}


def _stream_round(state: PlannerState, index: FactIndex, real: frozenset[str],
                  objects: dict[str, str], enumerated: dict[str, dict[str, int]],
                  made: Mapping[str, list[tuple[str, ...]]]) -> list[Fact]:
    """Assert what every stream instance over ``index`` could certify (joined only over the
    facts added since the stream's last round); new abstract outputs join ``objects``.
    Returns the new facts."""
    added: list[Fact] = []
    for external in state.externals.values():
        if not isinstance(external, Stream | ExternalPredicate):
            continue  # cost functions certify nothing
        if time.perf_counter() > state.deadline:
            raise SearchTimeout
        since = enumerated.get(external.name)
        enumerated[external.name] = index.sizes()
        for inputs in list(dict.fromkeys(state.bindings_of(external, index, since))):
            if time.perf_counter() > state.deadline:
                raise SearchTimeout
            for fact in _abstract_facts(state, external, inputs, real, objects,
                                        made.get(external.name, ())):
                if index.add(fact):
                    added.append(fact)
    return added


def _abstract_facts(state: PlannerState, external: Stream | ExternalPredicate,
                    inputs: tuple[str, ...], real: frozenset[str],
                    objects: dict[str, str], made: Iterable[tuple[str, ...]]
                    ) -> list[Fact]:
    """The facts one instance may still certify: for the stream's abstract output tuple and
    for each tuple in ``made`` (see the module doc); none when the instance over existing
    objects is exhausted (what it certified is known already). An instance of a
    ``:fluents`` stream is never taken as exhausted: it was exhausted in the state it was
    called in, another state may give it outputs."""
    if all(x in real for x in inputs) and not getattr(external, "fluents", ()):
        found = state.instances.get((external.name, inputs))
        if found is not None and found.exhausted:
            return []
    if isinstance(external, ExternalPredicate):
        mapping = dict(zip(external.head.args, inputs, strict=True))
        return instantiate_atoms((external.head,), mapping)
    abstract = tuple(f"{ABSTRACT_PREFIX}{external.name}:{output}"
                     for output in external.outputs)
    for name in abstract:
        objects.setdefault(name, OBJECT_TYPE)
    mapping = dict(zip(external.inputs, inputs, strict=True))
    mapping.update(zip(external.outputs, abstract, strict=True))
    facts = instantiate_atoms(external.certified, mapping)
    # For an earlier output tuple, only the atoms that link an input to an output are new:
    # those over outputs only hold already (its call certified them), and those over
    # inputs only are among the abstract tuple's facts.
    linking = tuple(atom for atom in external.certified
                    if any(a in external.inputs for a in atom.args)
                    and any(a in external.outputs for a in atom.args))
    if linking:
        for outputs in made:
            mapping.update(zip(external.outputs, outputs, strict=True))
            facts.extend(instantiate_atoms(linking, mapping))
    return facts


@dataclass
class Check:
    """Whether the goal is proven unreachable (``proven``), ``by`` what (or, unproven, why
    not), and the abstract search's size for the solve's stats."""

    proven: bool
    by: str
    stats: dict[str, object] = field(default_factory=dict)


RELAXATION_PROOF = "merge-safe relaxation: goal unreachable"
ABSTRACT_PROOF = "abstract task exact over known objects: goal unreachable"


def check_infeasibility(state: PlannerState) -> Check:
    """Prove the goal unreachable however many outputs each stream instance gives: first in
    the relaxation of the module docstring, then in the abstract task of
    :mod:`.abstract_task` (deletes and negation exact over known objects), searched for at
    most half of the time left (:func:`.abstract_task.budget_deadline`) and
    :data:`.abstract_task.MAX_EXPANSIONS` expansions per round. Past the deadline, on a
    construct either cannot represent, or when the search's budget runs out: unproven."""
    try:
        closure = relaxed_closure(state)
    except (SearchTimeout, UnsupportedConstruct) as error:
        return Check(False, f"relaxation not finished ({type(error).__name__})")
    if (GOAL_PREDICATE,) not in closure.index.members:
        return Check(True, RELAXATION_PROOF)
    try:
        verdict = search_abstract_task(closure, budget_deadline(state.deadline))
    except SearchTimeout:
        return Check(False, "abstract task: out of time")
    except Unrepresentable as error:
        return Check(False, f"abstract task: not representable ({error})")
    except (RecursionError, MemoryError, ValueError, KeyError, TypeError) as error:
        # A construct this check mishandles must not turn a solve into a traceback: the
        # fallback answers as it did before the check existed.
        return Check(False, f"abstract task: failed ({type(error).__name__})")
    stats: dict[str, object] = {
        "abstract_operators": verdict.operators, "abstract_expanded": verdict.expanded,
        "abstract_demoted": verdict.demoted,
        "abstract_demoted_predicates": list(verdict.demoted_predicates),
        "abstract_time_s": round(verdict.time_s, 6)}
    if verdict.reachable is False:
        return Check(True, ABSTRACT_PROOF, stats)
    if verdict.reachable is None:
        return Check(False, "abstract task: expansion budget spent", stats)
    return Check(False, "goal reachable in the abstract task", stats)
