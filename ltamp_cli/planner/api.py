"""The planner's entry point: :func:`solve`."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import (
    ALGORITHMS,
    PlannerConfig,
    PlannerState,
    goal_atoms,
    initial_state,
)
from ltamp_cli.planner.algorithms.companions import missed_outputs
from ltamp_cli.planner.algorithms.focused import solve_focused
from ltamp_cli.planner.algorithms.incremental import solve_incremental
from ltamp_cli.planner.algorithms.interleave import InterleavedIncremental, interleaved_incremental
from ltamp_cli.planner.algorithms.multiplicity import check_infeasibility, has_generators
from ltamp_cli.planner.algorithms.skeletons import solve_with_skeletons
from ltamp_cli.planner.gc_pacing import CollectionPacer, PausedCollection
from ltamp_cli.planner.pddl.syntax import Stream
from ltamp_cli.planner.problem import PlanningProblem
from ltamp_cli.planner.reclaim import Reclaimer
from ltamp_cli.planner.result import INFEASIBLE, TIMEOUT, Certificate, PlanResult
from ltamp_cli.planner.search.engine import SEARCH_ALGORITHMS
from ltamp_cli.planner.search.normalize import GoalFormulaError
from ltamp_cli.planner.search.skeleton import (
    check_constraints,
    equates_arguments,
    parse_constraints,
)
from ltamp_cli.planner.statistics import StreamStatistics
from ltamp_cli.planner.watchdog import CallTracker, RunningCall, run_until
from ltamp_cli.seeds import usable_seed
from ltamp_cli.threads import limited_threads

COST_EPSILON = 1e-6
LOGGER = logging.getLogger("ltamp")
# Tries at reading an abandoned worker's state while it may still change it.
ABANDONED_READ_ATTEMPTS = 5
# Automatic garbage collection is off while solves run (see :mod:`.gc_pacing`): one switch
# for the process, shared by concurrent solves.
_paused_gc = PausedCollection()


@dataclass
class _Run:
    """The algorithm ``name`` as a callable on a state, called once per anytime round; for
    the optimistic ones it keeps ``member``, the solve's incremental member (made at the
    first round when one applies, see :mod:`.algorithms.interleave`), which every later
    round goes on with (:meth:`.InterleavedIncremental.next_round`: one ``make_streams``,
    one grace and the member's samples per solve) and an unproven "infeasible" runs on.
    Kept here, not on the state: the member refers to the state."""

    name: str
    member: InterleavedIncremental | None = None
    rounds: int = 0

    def __call__(self, state: PlannerState) -> PlanResult:
        if self.name == "incremental":
            return solve_incremental(state)
        self.rounds += 1
        if self.rounds == 1:
            self.member = interleaved_incremental(state)
        elif self.member is not None:
            self.member.next_round()
        if self.name == "focused":
            return solve_focused(state, self.member)
        return solve_with_skeletons(state, self.name == "adaptive", self.member)


def _algorithm(name: str) -> Callable[[PlannerState], PlanResult]:
    return _Run(name)


def solve(problem: PlanningProblem, config: PlannerConfig | None = None) -> PlanResult:
    """Plan for ``problem``. Deterministic for a given ``config.seed``.

    With a finite ``config.success_cost`` the planner keeps looking for cheaper plans, reusing
    every sample, until one costs at most that or time runs out (anytime mode); the best plan
    found is returned with the cost of each improvement in ``stats["anytime_costs"]``.

    Returns within ``config.max_time`` seconds plus about half a second whatever the stream
    bindings do: the planner runs in a worker thread that is abandoned when a binding blocks
    past the deadline (see :mod:`ltamp_cli.planner.watchdog`); the result is then a timeout
    whose ``diagnostics["stopped_in"]`` names the stream call. Garbage collection while it
    runs is timed to keep clear of the deadline (:mod:`.gc_pacing`), and the memory of a
    solve that ends near its deadline is freed in the background after it returned
    (:mod:`.reclaim`): neither runs as one uninterruptible step past the deadline.
    """
    config = config or PlannerConfig()
    if isinstance(config.seed, bool) or not isinstance(config.seed, int):
        raise InputError(f"seed must be an integer, got {config.seed!r}")
    config = replace(config, seed=usable_seed(config.seed))
    check_config(config)
    config = resolve_constraints(problem, config)
    start = time.perf_counter()
    deadline = start + config.max_time
    tracker = CallTracker()
    holder: list[PlannerState] = []
    reclaimer = Reclaimer()
    refuse_unsupported(problem, config.algorithm)
    try:
        with _paused_gc(), limited_threads(config.threads):
            pacer = CollectionPacer(deadline, _paused_gc.caller_enabled)
            finished, result = run_until(
                lambda: _solve(problem, config, start, tracker, holder), deadline, tracker,
                reclaimer=reclaimer, tick=pacer.tick)
    except GoalFormulaError as error:
        if problem.goal_location is None:
            raise
        raise InputError(error.message, problem.goal_location) from None
    if not finished:
        result = _abandoned_result(holder[0] if holder else None, config, start, tracker)
    assert result is not None
    _hand_over(holder, reclaimer, start, deadline)
    return result


def _hand_over(holder: list[PlannerState], reclaimer: Reclaimer, start: float,
               deadline: float) -> None:
    """Give the solve's state (and the worker's locals captured near the deadline, already
    given) to ``reclaimer``, freed in the background when the deadline is too near for
    freeing them now: their deallocation takes at most about as long as building them did,
    so a solve that ends with more time left than it took frees them before returning (no
    thread is started), any other in the background, in bounded pieces (see
    :mod:`.reclaim`), frozen from the collector meanwhile
    (:meth:`.gc_pacing.PausedCollection.hold_frozen`). Emptied: nothing here keeps them
    alive."""
    reclaimer.give(holder)
    holder.clear()
    now = time.perf_counter()
    if reclaimer.has_frames or deadline - now < now - start:
        reclaimer.start(when_done=_paused_gc.hold_frozen())


def check_config(config: PlannerConfig) -> None:
    """Reject options the planner cannot run with (:class:`InputError`, one line)."""
    if config.algorithm not in ALGORITHMS:
        raise InputError(f"unknown algorithm {config.algorithm!r}: expected one of "
                         f"{', '.join(ALGORITHMS)}")
    if config.search not in SEARCH_ALGORITHMS:
        raise InputError(f"unknown search {config.search!r}: expected one of "
                         f"{', '.join(SEARCH_ALGORITHMS)}")
    max_time = config.max_time
    if (isinstance(max_time, bool) or not isinstance(max_time, int | float)
            or math.isnan(max_time) or max_time <= 0):
        raise InputError(f"max time: expected a positive number of seconds, got {max_time!r}")
    for flag in ("unit_costs", "eager_cheap_streams", "incremental_grounding",
                 "interleave"):
        value = getattr(config, flag)
        if not (isinstance(value, bool | np.bool_) or value in (0, 1)):  # "no" would be true
            raise InputError(f"{flag.replace('_', ' ')}: expected True or False, got "
                             f"{value!r:.40}")
    success_cost = config.success_cost
    if (isinstance(success_cost, bool) or not isinstance(success_cost, int | float)
            or math.isnan(success_cost) or success_cost < 0):
        # as the YAML field planner.success_cost: NaN would compare false with every cost
        raise InputError(f"success cost: expected a number >= 0 (or inf), got {success_cost!r}")
    max_cost = config.max_cost
    if (isinstance(max_cost, bool) or not isinstance(max_cost, int | float)
            or math.isnan(max_cost) or max_cost < 0):
        raise InputError(f"max cost: expected a number >= 0 (or inf), got {max_cost!r:.40}")
    if max_cost < math.inf and config.unit_costs:
        # The bounded search counts action costs; PDDLStream's bound would count actions.
        raise InputError("max cost with unit costs is not supported: the bound applies to "
                         "action costs (drop unit_costs, or bound the cost instead)")


def resolve_constraints(problem: PlanningProblem, config: PlannerConfig) -> PlannerConfig:
    """``config`` with its plan constraints in one form (``constraints``), checked against
    the domain: every pattern names an action ('*' any) with its number of arguments, since
    a misspelt pattern would otherwise only make the problem infeasible."""
    given = [name for name in ("skeleton", "skeletons", "constraints")
             if getattr(config, name)]
    if len(given) > 1:
        raise InputError(f"plan constraints given twice ({' and '.join(given)}): give "
                         "'skeleton' (one), 'skeletons' (one of several) or constraints")
    constraints = config.constraints
    if constraints is None:
        constraints = parse_constraints([config.skeleton] if config.skeleton
                                        else config.skeletons)
    if constraints is None:
        return config
    arities = {action.name: len(action.parameters) for action in problem.domain.actions}
    check_constraints(constraints, arities)
    return replace(config, skeleton=(), skeletons=(), constraints=constraints)


def refuse_unsupported(problem: PlanningProblem, algorithm: str) -> None:
    """Refuse, before solving, a construct the algorithm does not support (an answer of
    "infeasible" would be wrong): ``:fluents`` streams need a state to be called in, which
    only the algorithms that plan with optimistic stream outputs provide."""
    if algorithm != "incremental" or problem.stream_file is None:
        return
    for stream in problem.stream_file.streams:
        if stream.fluents:
            raise InputError(
                f"stream {stream.name!r} declares :fluents, which the incremental algorithm "
                "does not support: use --algorithm adaptive, binding or focused",
                stream.fluents_location)


WILD_FACTS_NOTE = "wild facts: the optimistic plans' failure proves nothing"
EQUATED_NOTE = ("plan constraints equate arguments that optimistic plans keep apart: their "
                "failure proves nothing")
COINCIDENCE_NOTE = ("a stream's future output may equal an object that exists already, "
                    "which the optimistic plans and the relaxation take to be new")
MULTIPLICITY_NOTE = ("a plan may need several distinct outputs of one stream instance, or a "
                     ":fluents stream's outputs in another state (the goal is reachable in "
                     "the merge-safe relaxation): one optimistic output per instance proves "
                     "nothing")


def _infeasibility_unproven(problem: PlanningProblem, config: PlannerConfig,
                            state: PlannerState, stats: dict[str, object] | None = None
                            ) -> str | None:
    """Why an optimistic algorithm's "infeasible" may be wrong (``None``: it is proven):
    some stream certifies facts it does not declare (wild outputs seen, or a stream with no
    :certified facts), which no optimistic plan can anticipate; plan constraints equate
    arguments that optimistic plans keep apart (distinct stream instances have distinct
    placeholders, yet their real outputs may be one object); or a plan may need two
    distinct outputs of one instance (:func:`.multiplicity.check_infeasibility` did not
    prove the goal unreachable; what it found goes to ``stats``)."""
    if problem.stream_file is None:
        return None
    missed = missed_outputs(state, state.companions)
    if missed is not None:
        return missed
    if config.algorithm == "incremental":
        return None
    if config.constraints is not None:
        known = {arg for atom in problem.init for arg in atom.args}
        known.update(constant.name for constant in problem.domain.constants)
        if equates_arguments(config.constraints, known):
            return EQUATED_NOTE
    if state.saw_wild_facts or any(not stream.certified and not stream.is_rule
                                   for stream in problem.stream_file.streams):
        return WILD_FACTS_NOTE
    _probe_uncalled_instances(state)
    if state.saw_wild_facts:
        return WILD_FACTS_NOTE
    coincidence = _coinciding_outputs(problem, state)
    if coincidence is not None:
        return f"{COINCIDENCE_NOTE} ({coincidence})"
    if not has_generators(state):
        return None
    check = check_infeasibility(state)
    if stats is not None:
        stats["infeasibility_check"] = check.by
        stats.update(check.stats)
    return None if check.proven else f"{MULTIPLICITY_NOTE}; {check.by}"


def _coinciding_outputs(problem: PlanningProblem, state: PlannerState) -> str | None:
    """Why a stream's future output may equal an object that exists already (``None``: no
    sign of it), which the relaxations behind an optimistic "infeasible" do not cover (they
    take every future output to be a new object): a stream output such an object already
    (:attr:`.PlannerState.coinciding_output`), or the goal names an object that no
    initial fact and no constant mentions, which only an output equal to it could bring in
    (a grid's goal cell reached by a neighbour stream: red-team round 8's "infeasible")."""
    if state.coinciding_output is not None:
        return state.coinciding_output
    if not has_generators(state):
        return None
    mentioned = {arg for atom in problem.init for arg in atom.args}
    mentioned.update(constant.name for constant in problem.domain.constants)
    for atom in goal_atoms(problem):
        for name in atom[1:]:
            if name in problem.objects and name not in mentioned:
                return f"the goal names {name!r}, which no initial fact mentions"
    return None


def _probe_uncalled_instances(state: PlannerState) -> None:
    """Call once every stream instance over the real facts that was never called (a stream
    may certify wild facts that the optimistic plans could not anticipate): one round of
    what the incremental algorithm does, within the time left."""
    for external in state.externals.values():
        if not isinstance(external, Stream) or external.fluents or external.is_rule:
            continue
        for inputs in list(state.bindings_of(external, state.facts)):
            if state.timed_out():
                return
            instance = state.instance(external.name, inputs)
            if instance.num_calls == 0:
                state.call(instance)


def _complete_with_incremental(problem: PlanningProblem, config: PlannerConfig,
                               state: PlannerState, statistics: StreamStatistics,
                               note: str, member: InterleavedIncremental | None = None
                               ) -> PlanResult:
    """The incremental algorithm, which calls every stream instance (and so finds wild
    facts and distinct outputs of one instance), for the time left; a timeout (not
    "infeasible") when it cannot run (:fluents). ``note``: why it runs. ``member``: the
    solve's interleaved incremental member (:mod:`.algorithms.interleave`), run on from
    where it stopped (also when the grace had not yet started it); a fresh incremental
    solve without one (``PlannerConfig.interleave`` off) or when it had ended (a timeout)."""
    remaining = state.deadline - time.perf_counter()
    if remaining <= 0 or any(s.fluents for s in problem.stream_file.streams):  # type: ignore[union-attr]
        result = state.result(TIMEOUT, None)
        result.diagnostics["infeasibility_unproven"] = note
        return result
    if math.isinf(remaining):
        # No time limit: this solve ends only with a plan or once every stream instance is
        # exhausted, possibly never; say why while it runs.
        LOGGER.warning("ltamp: no plan found by %s and infeasibility unproven (%s); the "
                       "incremental algorithm continues without a time limit (give max_time "
                       "to bound it)", config.algorithm, note)
    continued = member.finish() if member is not None else None
    if continued is not None and member is not None and member.member is not None:
        # The interleaved incremental member goes on where it stopped (its samples, rounds
        # and search budget kept) rather than a fresh incremental solve redoing its work.
        # (Both members' stream statistics are persisted by _solve.)
        continued = _unless_outputs_missed(continued, member.member, state, note,
                                           member.of_member)
        return _completed(continued, state, note)
    try:
        fallback = initial_state(problem, replace(config, algorithm="incremental"))
    except InputError as error:  # a make_streams that refuses a second call
        result = state.result(TIMEOUT, None)
        result.diagnostics["infeasibility_unproven"] = (
            f"{note}; the incremental algorithm could not run: {error.message}")
        return result
    statistics.update(state.stream_stats)
    # The solve's clock and deadline: its time_s and time_spent count from the solve's
    # start, not from the completion's.
    fallback.start_time = state.start_time
    fallback.history = statistics.totals
    fallback.tracker = state.tracker  # the watchdog follows (and may cancel) its calls too
    result = solve_incremental(fallback)
    result = _unless_outputs_missed(result, fallback, state, note)
    state.stream_stats = fallback.stream_stats
    return _completed(result, state, note)


def _unless_outputs_missed(result: PlanResult, claimer: PlannerState, state: PlannerState,
                           note: str,
                           annotate: Callable[[PlanResult], PlanResult] = lambda r: r
                           ) -> PlanResult:
    """``result``, or a timeout saying why when it is an "infeasible" of ``claimer`` whose
    generators were spent by the solve's other states (:mod:`.algorithms.companions`)."""
    if result.status != INFEASIBLE:
        return result
    missed = missed_outputs(claimer, [state, *state.companions])
    if missed is None:
        return result
    timeout = annotate(claimer.result(TIMEOUT, None))
    timeout.diagnostics["infeasibility_unproven"] = f"{note}; {missed}"
    return timeout


def _completed(result: PlanResult, state: PlannerState, note: str) -> PlanResult:
    """``result`` of the incremental completion, labelled, with the optimistic searches'
    explanation when unsolved (incremental gives none)."""
    result.stats["completed_by"] = f"incremental ({note})"
    if not result.solved:
        result.diagnostics["unreachable_goal_facts"] = state.unreachable_goal
        result.diagnostics["last_skeletons"] = state.last_skeletons
    return result


def _solve(problem: PlanningProblem, config: PlannerConfig, start: float,
           tracker: CallTracker, holder: list[PlannerState]) -> PlanResult:
    statistics = StreamStatistics.load(config.statistics_dir, problem.domain.name)
    tracker.running = RunningCall("make_streams", (), time.perf_counter())
    try:
        state = initial_state(problem, config)
    finally:
        tracker.running = None
    state.start_time = start
    state.tracker = tracker
    state.history = statistics.totals
    holder.append(state)
    run = _algorithm(config.algorithm)
    best = run(state)
    # The interleaved incremental member's "infeasible" is a proof already (every instance
    # exhausted, an exhaustive search): neither checked nor completed again.
    if best.status == INFEASIBLE and "solved_by" not in best.stats:
        check: dict[str, object] = {}
        unproven = _infeasibility_unproven(problem, config, state, check)
        if unproven is not None:
            interleaved = best.stats.get("interleaved")
            # (a wrapped algorithm, as in tests, has no member: a fresh incremental solve)
            member = run.member if isinstance(run, _Run) else None
            best = _complete_with_incremental(problem, config, state, statistics, unproven,
                                              member)
            if interleaved is not None and "interleaved" not in best.stats:
                best.stats["interleaved"] = interleaved  # the optimistic solve's member
        best.stats.update(check)
    improvements = [plan_cost(best, config)] if best.solved else []
    while (best.solved and plan_cost(best, config) > config.success_cost + COST_EPSILON
           and not state.timed_out()):
        state.cost_bound = plan_cost(best, config)
        better = run(state)
        if (not better.solved
                or plan_cost(better, config) >= plan_cost(best, config) - COST_EPSILON):
            break
        best = better
        improvements.append(plan_cost(best, config))
    if improvements:
        best.stats["anytime_costs"] = improvements
    if tracker.cancelled:
        return best  # abandoned: the caller has returned already; persist nothing
    statistics.update(state.stream_stats)
    # The interleaved member's calls are this solve's too (its own states' statistics,
    # added once: no other state shares them).
    member = run.member.member if isinstance(run, _Run) and run.member is not None else None
    if member is not None:
        statistics.update(member.stream_stats)
    statistics.save()
    best.stats["stream_history"] = statistics.summary()
    return best


def plan_cost(result: PlanResult, config: PlannerConfig) -> float:
    """A solved result's cost as the solve measures it: with ``unit_costs`` its number of
    actions (PDDLStream's cost then; the anytime mode's ``success_cost`` and bound count
    actions, else an "improvement" could be a longer plan), else its action costs."""
    if config.unit_costs and result.plan is not None:
        return float(len(result.plan))
    return result.cost


def _abandoned_result(state: PlannerState | None, config: PlannerConfig, start: float,
                      tracker: CallTracker) -> PlanResult:
    """The timeout result of a solve whose worker did not stop by the deadline, built from
    what the worker recorded so far (it may still be running: read, never written)."""
    running = tracker.running
    now = time.perf_counter()
    stopped_in = running.describe(now) if running is not None else "the planner"
    if state is None:
        return PlanResult(TIMEOUT, None, float("inf"), now - start,
                          {"algorithm": config.algorithm}, Certificate(),
                          diagnostics={"stopped_in": stopped_in})
    for _ in range(ABANDONED_READ_ATTEMPTS):
        try:
            result = state.result(TIMEOUT, None, known_facts=False)
            break
        except RuntimeError:  # a container changed size under the worker: read again
            continue
    else:
        result = PlanResult(TIMEOUT, None, float("inf"), now - start,
                            {"algorithm": config.algorithm}, Certificate())
    result.diagnostics["stopped_in"] = stopped_in
    result.time_s = time.perf_counter() - start
    return result
