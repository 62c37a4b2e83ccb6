"""A finite abstract task that keeps deletes and negation exact over the objects that exist,
searched to prove that no plan exists (issue #19: a sound, fast "infeasible").

:func:`.multiplicity.relaxed_goal_reachable` drops every delete, negation and inequality,
so a problem whose infeasibility rests on them (a token used up by its first use, a
precondition ``(not (Broken r))`` that no action makes true) is never proven infeasible
when a generator never ends. Merging objects can only hurt facts about the objects that
are merged, so this task relaxes only those.

**The abstraction.** ``R`` are the known objects (problem objects and values sampled so
far), ``F0`` the known facts. A real solution calls further stream instances, whose
outputs ``N`` are new objects (disjoint from ``R``; an output equal to a known object is
not covered, as in the optimistic algorithms), and then runs a plan. ``h`` maps each
object of ``R`` to itself and each new output to its stand-in (``#any:`` objects of
:func:`.multiplicity.relaxed_closure`: one per stream output, shared by all its
instances, since two instances may make the same new value). A future output equal to an
earlier output of its stream is that known object itself: the closure certifies the
stream's input-output facts for every earlier output too, so such facts are *open* below.
``M`` is the relaxed closure: every fact the relaxation reaches, which
contains ``h(f)`` for every fact ``f`` of every state of every real solution. A ground
fact over ``R ∪ A`` (``A`` the stand-ins) is

* *exact* when all its arguments are in ``R``, its predicate is not derived, and it is
  not a stream fact whose value is still open; a *static* exact fact (predicate changed by
  no action) is decided now (true iff in ``F0``); a *fluent* one is a state variable;
* *open* when its predicate is certified by a stream and not changed by actions, and
  either an argument is a stand-in or the fact is over ``R``, in ``M`` but not in ``F0``
  (a stream may still certify it); also, for simplicity, every fact of a predicate that is
  both certified and changed by actions, and of one certified by a stream whose facts hold
  only in some states (``:fluents``, a :domain fact that actions change);
* *monotone* when its predicate is changed by actions and not certified and an argument is
  a stand-in (or it was *demoted*, below): a state variable that is added but never
  deleted.

Abstract states hold the true exact fluent facts and the monotone facts added so far. A
real action ``a(x)`` maps to ``a(h(x))``, which this task contains (its positive
preconditions map into ``M``, whose joins ground this task), with these conditions:
exact literals as written; a positive monotone literal as written (a real fact over a new
object was added earlier on the path, and so was its image); a negative monotone or open
literal dropped; a positive open literal dropped (it is in ``M``); ``x = y`` as written
(``h`` keeps equality); ``x != y`` dropped when both sides are stand-ins, else as written
(``h`` is injective on ``R`` and ``R ∩ A`` is empty). Derived predicates get two copies:
an upper one (the original name: rules as above) and a lower one (``%lo:``: rule
instances over ``R`` only, where an open or monotone literal, or a stand-in, kills the
instance, a negated fact outside ``M`` holds, and negated derived facts read the upper
copy); by induction over the strata, lower <= real <= upper in every state, and a
condition reads the upper copy positively and the lower one negatively. The lower copy
only counts instances over ``R``: a universal condition (``forall`` is ``not aux``) then
only fails for a counterexample that surely exists. Effects: on an exact fact, as written
when the condition is decided exactly; when it is not (a literal dropped as above, a
stand-in in it, a derived literal), the action is split in two, with the effect (under the
condition's exact part and the derived upper / lower copies) and without it (more than
:data:`MAX_SPLIT_EFFECTS` such effects in one action: their facts are *demoted* to
monotone, and the task is built again); adds of monotone facts under the same relaxed
condition; deletes of monotone facts and every effect on an open fact dropped. Action
costs are ignored (reachability only).

By induction over a real plan, each of its states ``s`` maps to a state of this task
reached by the mapped actions (choosing the split copy that agrees with the real effect),
whose exact part equals the exact facts of ``s`` and whose monotone part contains the
image of every monotone fact of ``s``. So the goal (the upper copy of ``%goal``)
unreachable here proves that no plan exists, however many distinct outputs it would use.

**The search.** Monotone facts are never deleted and only read positively (negated ones
are dropped, lower copies never read them, upper copies and relaxed conditions only gain
from them), so a state with more of them can do all that one with fewer can. States are
therefore merged by their exact part, each holding the union of the monotone facts of
every path found to it; the induction above still holds (each real state's image is
covered by the merged state of its exact part). Demoting any fact (or every fact of a
predicate) from exact to monotone keeps the argument (its real value is then only
over-approximated), so when a round runs out of expansions the fluent predicate with the
most exact facts is demoted (typically the robot's configuration) and the coarser task is
searched again; a first, coarse try demotes every predicate of many exact facts at once.
Operators that act alike on the exact part are expanded as one (their monotone adds
united), as the merged states allow.

Cases where reading a literal exactly would be unsound, each a solvable problem in
``bench/infeasible_corpus.py`` that such a reading answers "infeasible" (and
``tests/planner/test_abstract_infeasibility.py`` solves): a negated fact of an output
(``visits_four_outputs``), an inequality between two outputs of one instance
(``looks_three_three_tokens``), a conditional effect on a known fact whose condition
mentions an output (``visits_when_fresh``), a derived fact about known objects derived
through an output (``visits_busy_derived``).
"""

from __future__ import annotations

import itertools
import math
import time
from collections import Counter, deque
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from ltamp_cli.errors import InputError
from ltamp_cli.planner.pddl.syntax import EQUALITY, ExternalPredicate, Stream, is_variable
from ltamp_cli.planner.search.clock import check_deadline
from ltamp_cli.planner.search.ground import (
    Fact,
    FactIndex,
    GroundAction,
    GroundAxiom,
    GroundEffect,
    Grounding,
    RuleSet,
    _Rule,
    head_bindings,
    semi_naive_fixpoint,
)
from ltamp_cli.planner.search.normalize import (
    GOAL_PREDICATE,
    LiftedLiteral,
    NormalAction,
    NormalAxiom,
)
from ltamp_cli.planner.search.task import Task

LOWER_PREFIX = "%lo:"
# Effects on exact facts with an undecided condition split one action into 2^k copies; more
# than this many in one action demote their facts to monotone instead.
MAX_SPLIT_EFFECTS = 3
# Expansions of one round of the abstract search, and rounds (each coarser than the last)
# before it gives up (unproven).
MAX_EXPANSIONS = 2_000
MAX_ROUNDS = 4
# A predicate with more exact facts than this is monotone in the first, coarse try.
COARSE_FACTS = 12
# Rule instances turned into abstract actions between two deadline checks.
DEADLINE_STRIDE = 256


class Unrepresentable(Exception):
    """A rule this task cannot represent (a variable no literal binds, axioms that are not
    stratified): the caller treats infeasibility as unproven."""


@dataclass
class Verdict:
    """The abstract search's answer: ``reachable`` (``None``: undecided, budget or
    deadline), with its size for the solve's stats."""

    reachable: bool | None
    operators: int = 0
    expanded: int = 0
    demoted: int = 0
    time_s: float = 0.0
    demoted_predicates: tuple[str, ...] = ()


@dataclass
class _Kinds:
    """How each ground fact is read (see the module docstring)."""

    real: frozenset[str]
    known: set[Fact]
    closure: set[Fact]
    fluent: frozenset[str]
    derived: frozenset[str]
    certified: frozenset[str]
    # Certified by :fluents or exogenous streams: true only in some states.
    contextual: frozenset[str] = frozenset()
    demoted: set[Fact] = field(default_factory=set)
    demoted_predicates: set[str] = field(default_factory=set)

    def abstract(self, fact: Fact) -> bool:
        return any(arg not in self.real for arg in fact[1:])

    def kind(self, fact: Fact) -> str:
        """'static', 'fluent' (exact), 'open' or 'monotone' (a basic fact)."""
        predicate = fact[0]
        if predicate in self.contextual:
            return "open"
        if predicate in self.fluent:
            if predicate in self.certified:
                return "open"
            if (fact in self.demoted or predicate in self.demoted_predicates
                    or self.abstract(fact)):
                return "monotone"
            return "fluent"
        if self.abstract(fact):
            return "open"
        if predicate in self.certified and fact not in self.known and fact in self.closure:
            return "open"
        return "static"


@dataclass
class Closure:
    """A relaxed closure (:func:`.multiplicity.relaxed_closure`): ``index`` holds every
    fact the relaxation reaches, ``actions`` and ``axioms`` are normalised over its objects
    (known and stand-ins), ``real`` the known objects, ``known`` the known facts (with the
    known objects' type facts), ``externals`` the streams."""

    actions: list[NormalAction]
    axioms: list[NormalAxiom]
    index: FactIndex
    real: frozenset[str]
    known: set[Fact]
    externals: Iterable[object]


def certified_predicates(externals: Iterable[object]
                         ) -> tuple[frozenset[str], frozenset[str]]:
    """Predicates some stream or external predicate certifies, and those certified by a
    stream whose facts hold only in some states (``:fluents``, or a :domain fact that
    actions change)."""
    names: set[str] = set()
    contextual: set[str] = set()
    for external in externals:
        if isinstance(external, Stream):
            names.update(atom.predicate for atom in external.certified)
            if external.fluents or external.fluent_domain:
                contextual.update(atom.predicate for atom in external.certified)
        elif isinstance(external, ExternalPredicate):
            names.add(external.head.predicate)
    return frozenset(names), frozenset(contextual)


def search_abstract_task(source: Closure, deadline: float,
                         max_expansions: int = MAX_EXPANSIONS,
                         max_rounds: int = MAX_ROUNDS) -> Verdict:
    """Build the abstract task of the module docstring over ``source`` (a relaxed closure:
    its index holds every reachable fact, its rules are normalised over its objects) and
    search it until ``deadline`` (``perf_counter`` seconds), ``max_expansions`` per round.

    A round that runs out of expansions demotes the fluent predicate with the most exact
    facts in the task to monotone (the robot's configuration, say: a sound, coarser
    abstraction with far fewer exact states) and searches again, at most ``max_rounds``
    times. A reachable goal ends the rounds (coarser tasks reach it too)."""
    start = time.perf_counter()
    derived = frozenset(axiom.predicate for axiom in source.axioms)
    certified, contextual = certified_predicates(source.externals)
    kinds = _Kinds(
        source.real, source.known, source.index.members,
        frozenset(e.predicate for a in source.actions for e in a.effects),
        derived, certified, contextual)
    instances = _ground_instances(source, deadline)
    verdict = Verdict(None)
    task = _task(instances, kinds, deadline)
    coarse = {predicate for predicate, count in _exact_counts(task, kinds).items()
              if count > COARSE_FACTS}
    if coarse:
        # First a cheap try with every predicate of many exact facts monotone (a proof
        # that needs none of them exact comes in a few expansions); then from fully exact.
        fine_demoted = set(kinds.demoted)
        kinds.demoted_predicates = coarse
        verdict = _round(_task(instances, kinds, deadline), kinds, deadline, max_expansions,
                         verdict, start)
        if verdict.reachable is False:
            return verdict
        kinds.demoted_predicates, kinds.demoted = set(), fine_demoted
    for _ in range(max_rounds):
        verdict = _round(task, kinds, deadline, max_expansions, verdict, start)
        if verdict.reachable is not None:
            break
        counts = _exact_counts(task, kinds)
        if not counts:
            break
        kinds.demoted_predicates.add(counts.most_common(1)[0][0])
        task = _task(instances, kinds, deadline)
    return verdict


def _round(task: Task, kinds: _Kinds, deadline: float, max_expansions: int,
           previous: Verdict, start: float) -> Verdict:
    """One search of ``task`` (expansions added to ``previous``'s)."""
    monotone = frozenset(
        number for number, fact in enumerate(task.facts)
        if not task.is_derived[number] and fact[0] in kinds.fluent
        and kinds.kind(fact) == "monotone")
    if any(axiom.head == (GOAL_PREDICATE,) for axiom in task.axioms):
        reachable, expanded = _explore(task, monotone, deadline, max_expansions)
    else:  # no goal rule survived (each needs a fact both true and false, say)
        reachable, expanded = False, 0
    return Verdict(reachable, len(task.operators), previous.expanded + expanded,
                   len(kinds.demoted), time.perf_counter() - start,
                   tuple(sorted(kinds.demoted_predicates)))


def _exact_counts(task: Task, kinds: _Kinds) -> Counter[str]:
    """Exact fluent facts of ``task`` per predicate."""
    return Counter(fact[0] for number, fact in enumerate(task.facts)
                   if not task.is_derived[number] and fact[0] in kinds.fluent
                   and kinds.kind(fact) == "fluent")


def _task(instances: list[_Instance], kinds: _Kinds, deadline: float) -> Task:
    """The abstract task under ``kinds`` (demoting the facts of effects that would split
    an action too often, until none does)."""
    while True:
        grounding, demote = _build(instances, kinds, deadline)
        if not demote:
            break
        kinds.demoted.update(demote)
    init = {f for f in kinds.known
            if f[0] in kinds.fluent and kinds.kind(f) in ("fluent", "monotone")}
    try:
        return Task(grounding, init, deadline)
    except InputError as error:  # derived predicates not stratified
        raise Unrepresentable(str(error)) from None


def _explore(task: Task, monotone: frozenset[int], deadline: float, max_expansions: int
             ) -> tuple[bool | None, int]:
    """Whether the goal is reachable in ``task`` (``None``: budget spent), and the
    expansions made. States are merged by their exact part (facts not in ``monotone``),
    each holding the union of the monotone facts of every path found to it: monotone facts
    are never deleted and only read positively (they only enable), so every path of the
    task is covered by one of the merged states, and the search visits each exact part
    again only when its monotone facts grew (without merging, the subsets of monotone
    facts multiply the states: 20,000 expansions did not finish a two-block problem)."""
    plain = _plain_effects(task, monotone)
    init_exact = task.init - monotone
    grown: dict[frozenset[int], frozenset[int]] = {init_exact: task.init & monotone}
    queue: deque[frozenset[int]] = deque([init_exact])
    queued = {init_exact}
    expanded = 0
    while queue:
        if expanded >= max_expansions:
            return None, expanded
        if expanded % 16 == 0:
            check_deadline(deadline)
        exact = queue.popleft()
        queued.discard(exact)
        state = exact | grown[exact]
        vector = task.state_vector(state)
        if task.is_goal(vector):
            return True, expanded
        expanded += 1
        # Operators without conditional effects are grouped by their effect on the exact
        # part (moves between configurations differ only in monotone facts): one child
        # per group, with the union of the group's monotone adds.
        children: dict[tuple[frozenset[int], frozenset[int]], set[int]] = {}
        for op in task.applicable(vector).tolist():
            entry = plain[op]
            if entry is not None:
                children.setdefault(entry[0], set()).update(entry[1])
                continue
            child = task.successor(state, vector, op)
            key = (exact - child, child - monotone - exact)
            children.setdefault(key, set()).update(child & monotone)
        for (deletes, adds), monotone_adds in children.items():
            child_exact = (exact - deletes) | adds
            known = grown.get(child_exact)
            if known is not None and monotone_adds <= known and grown[exact] <= known:
                continue
            more = grown[exact].union(monotone_adds)
            grown[child_exact] = more if known is None else known | more
            if child_exact not in queued:
                queued.add(child_exact)
                queue.append(child_exact)
    return False, expanded


def _plain_effects(task: Task, monotone: frozenset[int]
                   ) -> list[tuple[tuple[frozenset[int], frozenset[int]], frozenset[int]] | None]:
    """Per operator without conditional effects: ((exact deletes, exact adds), monotone
    adds); ``None`` for the others (their effects depend on the state)."""
    plain: list[tuple[tuple[frozenset[int], frozenset[int]], frozenset[int]] | None] = []
    for op in task.operators:
        if op.conditional:
            plain.append(None)
            continue
        adds = frozenset(op.adds)
        plain.append(((frozenset(op.deletes) - monotone, adds - monotone), adds & monotone))
    return plain


_Instance = tuple[_Rule, dict[str, str]]


def _ground_instances(source: Closure, deadline: float) -> list[_Instance]:
    """Every rule instance whose positive literals hold in the closure (the closure is a
    fixpoint: nothing new is reached), and the instances of negative-only derived
    predicates whose facts a grounded rule negates."""
    rule_set = RuleSet(source.actions, source.axioms)
    index = source.index
    found: list[_Instance] = []
    seen: set[tuple[int, tuple[str, ...]]] = set()

    def emit(rule: _Rule, binding: dict[str, str], delta: list[Fact]) -> None:
        binding = _bind_equalities(rule, binding)
        if binding is None:
            return
        key = (id(rule), tuple(binding.get(v, v) for v in rule.variables))
        if key not in seen:
            seen.add(key)
            found.append((rule, binding))

    semi_naive_fixpoint(rule_set, index, None, emit, deadline)
    done: set[Fact] = set()
    start = 0
    while True:
        needed = []
        for rule, binding in found[start:]:
            for literal in (*rule.negative, *_condition_literals(rule)):
                if not literal.positive and literal.predicate in rule_set.demanded:
                    fact = (literal.predicate, *_bound(literal.args, binding))
                    if fact not in done:
                        done.add(fact)
                        needed.append(fact)
        start = len(found)
        if not needed:
            return found
        for fact in needed:
            for rule in rule_set.demanded[fact[0]]:
                for binding in head_bindings(rule, fact, index):
                    emit(rule, binding, [])


def _condition_literals(rule: _Rule) -> Iterable[LiftedLiteral]:
    if isinstance(rule.source, NormalAction):
        for effect in rule.source.effects:
            yield from effect.condition


def _bind_equalities(rule: _Rule, binding: dict[str, str]) -> dict[str, str] | None:
    """``binding`` extended through positive equalities with one side unbound (``None``:
    an equality between two bound names fails)."""
    binding = dict(binding)
    for literal in rule.equalities:
        if not literal.positive:
            continue
        left, right = (binding.get(a, a) for a in literal.args)
        if is_variable(left) and is_variable(right):
            raise Unrepresentable(f"unbound equality {literal}")
        if is_variable(left):
            binding[left] = right
        elif is_variable(right):
            binding[right] = left
        elif left != right:
            return None
    return binding


def _bound(args: Iterable[str], binding: Mapping[str, str]) -> tuple[str, ...]:
    ground = tuple(binding.get(a, a) for a in args)
    if any(is_variable(a) for a in ground):
        raise Unrepresentable(f"unbound variable in {ground}")
    return ground


class _Dead(Exception):
    """A literal that can never hold: the instance (or effect) is not part of the task."""


@dataclass
class _Condition:
    pos: list[Fact] = field(default_factory=list)
    neg: list[Fact] = field(default_factory=list)
    exact: bool = True  # decided as the real condition is (no literal relaxed)


def _literals(literals: Iterable[LiftedLiteral], binding: Mapping[str, str], kinds: _Kinds,
              mode: str, condition: _Condition) -> None:
    """Add the abstract reading of ``literals`` to ``condition``; raise :class:`_Dead` when
    one cannot hold. ``mode``: 'upper' (preconditions, upper axiom copies), 'lower' (lower
    copies: certain truth only) or 'effect' (an effect condition, where a stand-in may come
    from a quantifier over objects that need not exist: relaxed)."""
    for literal in literals:
        fact = (literal.predicate, *_bound(literal.args, binding))
        positive = literal.positive
        if literal.predicate == EQUALITY:
            _equality(fact, positive, kinds, mode, condition)
            continue
        if mode == "effect" and kinds.abstract(fact):
            condition.exact = False
            continue
        if literal.predicate in kinds.derived:
            condition.exact = False
            lower = (LOWER_PREFIX + fact[0], *fact[1:])
            if mode == "lower":
                (condition.pos if positive else condition.neg).append(
                    lower if positive else fact)
            else:
                (condition.pos if positive else condition.neg).append(
                    fact if positive else lower)
            continue
        kind = kinds.kind(fact)
        if kind == "static":
            if (fact in kinds.known) != positive:
                raise _Dead
        elif kind == "fluent":
            (condition.pos if positive else condition.neg).append(fact)
        elif mode == "lower":
            if positive or fact in kinds.closure:
                raise _Dead  # not surely true / surely false
        elif kind == "monotone" and positive:
            condition.exact = False  # an upper bound: it may have been deleted since
            condition.pos.append(fact)
        else:  # open, or a negated monotone fact: relaxed
            condition.exact = False
            if positive and mode != "effect" and fact not in kinds.closure:
                raise _Dead


def _equality(fact: Fact, positive: bool, kinds: _Kinds, mode: str,
              condition: _Condition) -> None:
    left, right = fact[1], fact[2]
    merged = left == right and left not in kinds.real  # two outputs may share a stand-in
    if merged and mode != "lower":
        condition.exact = False
        return
    if (left == right) != positive:
        raise _Dead


def _build(instances: list[_Instance], kinds: _Kinds, deadline: float
           ) -> tuple[Grounding, set[Fact]]:
    """The abstract grounding, and the facts to demote (non-empty: build again)."""
    actions: list[GroundAction] = []
    axioms: list[GroundAxiom] = []
    demote: set[Fact] = set()
    for number, (rule, binding) in enumerate(instances):
        if number % DEADLINE_STRIDE == 0:
            check_deadline(deadline)
        source = rule.source
        if isinstance(source, NormalAxiom):
            axioms.extend(_axiom_copies(rule, source, binding, kinds))
        else:
            actions.extend(_action_copies(rule, source, binding, kinds, demote))
    derived = kinds.derived | {LOWER_PREFIX + p for p in kinds.derived}
    grounding = Grounding(actions, axioms, set(kinds.closure), frozenset(),
                          frozenset(derived))
    return grounding, demote


def _axiom_copies(rule: _Rule, source: NormalAxiom, binding: dict[str, str],
                  kinds: _Kinds) -> list[GroundAxiom]:
    head = (source.predicate, *_bound(source.head_args, binding))
    copies = []
    upper = _Condition()
    try:
        _literals((*rule.positive, *rule.negative, *rule.equalities), binding, kinds,
                  "upper", upper)
        if not set(upper.pos) & set(upper.neg):  # else it never holds
            copies.append(GroundAxiom(head, tuple(upper.pos), tuple(upper.neg)))
    except _Dead:
        pass
    if source.predicate == GOAL_PREDICATE or kinds.abstract(head) or any(
            value not in kinds.real for value in binding.values()):
        return copies
    lower = _Condition()
    try:
        _literals((*rule.positive, *rule.negative, *rule.equalities), binding, kinds,
                  "lower", lower)
    except _Dead:
        return copies
    if not set(lower.pos) & set(lower.neg):
        copies.append(GroundAxiom((LOWER_PREFIX + head[0], *head[1:]), tuple(lower.pos),
                                  tuple(lower.neg)))
    return copies


def _action_copies(rule: _Rule, source: NormalAction, binding: dict[str, str],
                   kinds: _Kinds, demote: set[Fact]) -> list[GroundAction]:
    pre = _Condition()
    try:
        _literals((*rule.positive, *rule.negative, *rule.equalities), binding, kinds,
                  "upper", pre)
    except _Dead:
        return []
    if set(pre.pos) & set(pre.neg):
        return []  # never applicable
    certain: list[GroundEffect] = []
    split: list[GroundEffect] = []
    for effect in source.effects:
        fact = (effect.predicate, *_bound(effect.args, binding))
        kind = kinds.kind(fact)
        if kind == "open" or (kind == "monotone" and not effect.positive):
            continue
        condition = _Condition()
        try:
            _literals(effect.condition, binding, kinds, "effect", condition)
        except _Dead:
            continue
        ground = GroundEffect(tuple(condition.pos), tuple(condition.neg), fact,
                              effect.positive)
        if kind == "monotone" or condition.exact:
            certain.append(ground)
        else:
            split.append(ground)
    if len(split) > MAX_SPLIT_EFFECTS:
        demote.update(effect.fact for effect in split)
        return []
    args = _bound(source.parameters, binding)
    copies = []
    for chosen in itertools.product((True, False), repeat=len(split)):
        effects = certain + [e for e, keep in zip(split, chosen, strict=True) if keep]
        copies.append(GroundAction(source.name, args, tuple(pre.pos), tuple(pre.neg),
                                   tuple(effects), 1.0))
    return copies


def budget_deadline(deadline: float, share: float = 0.5) -> float:
    """The abstract search's deadline (``perf_counter`` seconds): at most ``share`` of the
    time left before ``deadline`` (the rest is the incremental fallback's, which may find a
    plan that needs distinct outputs); no limit when the solve has none. Its work is bounded
    by :data:`MAX_EXPANSIONS` x :data:`MAX_ROUNDS`, not by a wall-clock share of the solve
    so far: an answer that depended on the machine's load (a proof at load 2, a timeout at
    load 12, seen in the tests) would make "infeasible" irreproducible."""
    if math.isinf(deadline):
        return deadline
    now = time.perf_counter()
    return now + max(0.0, deadline - now) * share
