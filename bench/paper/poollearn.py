"""Learning curves over a trial pool (experiments 2 and 3): F1 at every checkpoint, the
success rate of the most confident control (simulated) at the chosen ones."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from bench.paper.common import CheckpointLog, Context, LiveScore, first_valid_lazy
from bench.paper.pools import Pool, SkillBackends, get_pool, skill_backend
from ltamp_cli.backends.protocol import SkillBackend, SkillSpec
from ltamp_cli.learning.active import (
    GP_STRATEGIES,
    LearningConfig,
    LearningResult,
    learn_from_pool,
)
from ltamp_cli.learning.metrics import Evaluation, HeldOutSet, SkillEvaluator
from ltamp_cli.learning.model import PhysicalValidity, SkillModel


class CheckpointEvaluator(SkillEvaluator):
    """F1 at every checkpoint; the (expensive, simulated) success rate only at ``success_at``.

    ``logged`` (``{n_trials: entry}``, a :class:`~bench.paper.common.CheckpointLog`'s
    entries of this job) are checkpoints an interrupted run already evaluated: they are
    read back, not recomputed, and the true score (a :class:`~bench.paper.common.LiveScore`)
    seeks past the trials they ran, so later checkpoints get the trial seeds an
    uninterrupted run gives them. ``record`` receives every newly evaluated checkpoint's
    entry (to append to the log, with the CPU seconds since the previous one). The model
    must still be fitted at a logged checkpoint: the learner's fits there shape the later
    ones (warm starts, random draws).
    """

    def __init__(self, spec: SkillSpec, heldout: HeldOutSet | None,
                 true_score: Callable[[np.ndarray, np.ndarray], np.ndarray] | None,
                 contexts: np.ndarray | None, is_valid: PhysicalValidity | None,
                 success_at: set[int], seed: int, n_candidates: int,
                 logged: Mapping[int, Mapping[str, Any]] | None = None,
                 record: Callable[[dict[str, Any]], Any] | None = None) -> None:
        super().__init__(spec, heldout, true_score, contexts, is_valid, seed, n_candidates)
        self.success_at = success_at
        self.logged = dict(logged or {})
        self.record = record
        self._cpu = time.process_time()

    def evaluate(self, model: SkillModel, n_trials: int, success: bool = True) -> Evaluation:
        entry = self.logged.get(n_trials)
        if entry is not None:
            return self._replay(entry)
        evaluation = super().evaluate(model, n_trials, success and n_trials in self.success_at)
        if self.record is not None:
            self.record({"n_trials": n_trials, "f1": evaluation.f1,
                         "success_rate": evaluation.success_rate,
                         "successes": (None if evaluation.successes is None
                                       else list(evaluation.successes)),
                         "scorer": getattr(self.true_score, "position", None),
                         # this process's CPU seconds since the job's last checkpoint
                         # (fits, F1, θ*; a measurement, never read back)
                         "cpu_s": round(time.process_time() - self._cpu, 2)})
        self._cpu = time.process_time()
        return evaluation

    def _replay(self, entry: Mapping[str, Any]) -> Evaluation:
        """A logged checkpoint's evaluation, with the true score moved past its trials."""
        position = entry.get("scorer")
        if position is not None:
            if not isinstance(self.true_score, LiveScore):
                raise ValueError("a logged checkpoint ran live trials, but this job's true "
                                 "score cannot seek past them")
            self.true_score.seek(int(position))
        successes = entry.get("successes")
        return Evaluation(int(entry["n_trials"]), entry.get("f1"), entry.get("success_rate"),
                          None if successes is None else tuple(bool(s) for s in successes))


def resume_from(log: CheckpointLog, key: str) -> dict[str, Any]:
    """:class:`CheckpointEvaluator` keyword arguments that resume job ``key`` from ``log``
    (its logged checkpoints) and log every checkpoint it evaluates."""
    return {"logged": log.get(key), "record": lambda entry: log.put(key, entry)}


#: How many valid candidates the GP's θ* uses (``LevelSetModel.most_confident_control``'s
#: ``n_restarts``: its L-BFGS-B starts); the other models use the first valid one only.
GP_THETA_STARTS = 3


def theta_validity(test: PhysicalValidity, strategy: str) -> PhysicalValidity:
    """The validity test for θ* of a ``strategy`` model: lazy (:func:`first_valid_lazy`),
    one control at a time, until as many valid ones as its θ* uses are found (3 for the GP,
    1 for the others). Same θ* as the full test; with :func:`memoized_validity` underneath a
    one-control chunk costs nothing extra (a pour pre-check takes the same ~33 ms per
    control alone or in a batch of 8), while every control checked beyond the last needed
    one was wasted."""
    need = GP_THETA_STARTS if strategy in GP_STRATEGIES else 1
    return first_valid_lazy(test, chunk=1, need=need)


def memoized_validity(is_valid: PhysicalValidity, limit: int = 500_000) -> PhysicalValidity:
    """``is_valid`` remembering each (context, control)'s verdict (exact float bytes).

    The pre-check is deterministic and per control, and θ*'s candidates repeat: a job's
    evaluator draws the same candidates (its own seed) for each context at every checkpoint,
    and the learners of one seed share them, so the best-ranked candidates are checked again
    and again (a SAPIEN pour check is ~40 ms, most of a θ* argmax). Verdicts are the same as
    the wrapped test's; after ``limit`` entries the memory starts afresh.
    """
    memo: dict[tuple[bytes, bytes], bool] = {}

    def test(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        controls = np.atleast_2d(np.asarray(controls, dtype=float))
        where = np.asarray(context, dtype=float).tobytes()
        keys = [(where, control.tobytes()) for control in controls]
        missing = [i for i, key in enumerate(keys) if key not in memo]
        if missing:
            if len(memo) + len(missing) > limit:
                memo.clear()
            verdicts = np.asarray(is_valid(context, controls[missing]), dtype=bool)
            memo.update((keys[i], bool(v)) for i, v in zip(missing, verdicts, strict=True))
        return np.array([memo[key] for key in keys], dtype=bool)

    return test


#: CPU seconds of one simulated θ* trial per (engine, skill), from the fidelity engine rows
#: (``docs/results/fidelity/engine.json``; loaded 2-core machine): they only order the work.
THETA_TRIAL_CPU_S = {("pybullet", "pour"): 1.13, ("pybullet", "scoop"): 5.46,
                     ("sapien", "pour"): 0.21, ("sapien", "scoop"): 1.28}


def theta_trials(sizes: Mapping[str, Any], learners: int) -> int:
    """Simulated θ* trials of one skill: learners × seeds × checkpoints × contexts, counting
    only the checkpoints at which each seed simulates (:func:`success_checkpoints`)."""
    per_learner = sum(len(success_checkpoints(sizes, seed)) for seed in range(sizes["seeds"]))
    return learners * per_learner * int(sizes["contexts"])


def job_sizes(sizes: Mapping[str, Any], skill: str) -> Mapping[str, Any]:
    """What the logged jobs of ``skill`` depend on (their job-log hash): the sizes with only
    this skill's engine. With one engine for every skill (quick, standard) that is the sizes
    themselves, so their logs stay valid; at full size (``skill_backends``) another skill's
    engine is left out, so moving the scoop to another engine keeps the pour's jobs."""
    if "skill_backends" not in sizes:
        return sizes
    own = {key: value for key, value in sizes.items() if key != "skill_backends"}
    return {**own, "skill_backend": skill_backend(sizes, skill)}


def skill_parts(sizes: Mapping[str, Any], learners: int) -> list[tuple[str, float]]:
    """A pooled experiment's parts, one per skill, with estimated CPU seconds (its θ*
    trials): a part needs only its own skill's pool, so one skill's jobs can run while
    another's pool is still being collected."""
    return [(skill, theta_trials(sizes, learners)
             * THETA_TRIAL_CPU_S.get((skill_backend(sizes, skill), skill), 0.01) + 10.0)
            for skill in sizes["skills"]]


def require_part(experiment: str, ctx: Context, sizes: Mapping[str, Any], part: str) -> None:
    """Raise ``KeyError`` unless ``part`` is one of the skills of ``experiment``'s sizes."""
    if part not in sizes["skills"]:
        raise KeyError(f"{experiment} has no part {part!r} in {ctx.mode} mode")


def pooled_skill(ctx: Context, sizes: Mapping[str, Any], backends: SkillBackends, skill: str
                 ) -> tuple[SkillBackend, Pool, SkillSpec, np.ndarray, PhysicalValidity]:
    """What every job of ``skill`` in a pooled experiment shares: its engine's backend, its
    pool (collected or restored), its spec, the held-out θ* contexts ``(contexts, dα)`` and
    the memoised full validity test (:func:`memoized_validity`; a job's θ* takes it through
    :func:`theta_validity`)."""
    backend = backends[skill]
    pool = get_pool(ctx, skill_backend(sizes, skill), skill, sizes["n_train"], sizes["n_test"])
    contexts = held_out_contexts(backend, skill, sizes["contexts"], seed=3)

    def full_test(context: Any, controls: Any) -> Any:
        return backend.is_valid(skill, context, controls)

    return backend, pool, backend.skills()[skill], contexts, memoized_validity(full_test)


def success_checkpoints(sizes: Mapping[str, Any], seed: int) -> set[int]:
    """The checkpoints (trials) at which seed ``seed`` simulates the success rate:
    ``sizes["success_at"]`` for the first ``sizes["success_seeds"]`` seeds (default: all
    ``sizes["seeds"]``), none for the others, which measure only F1. The paper evaluates
    the success rate on 5 shuffles and F1 on 10 (section 6.1.1-6.1.2)."""
    if seed < int(sizes.get("success_seeds", sizes["seeds"])):
        return set(sizes["success_at"])
    return set()


def held_out_contexts(backend: SkillBackend, skill: str, n: int, seed: int) -> np.ndarray:
    """``n`` contexts ``(n, dα)`` from a stream no pool trial uses (held-out objects)."""
    spec = backend.skills()[skill]
    rng = np.random.default_rng([seed, 77])
    return np.array([backend.sample_context(skill, rng) for _ in range(n)]).reshape(
        n, spec.context.dim)


def pool_curve(pool: Pool, spec: SkillSpec, config: LearningConfig, eval_every: int,
               evaluator: SkillEvaluator) -> tuple[list[dict[str, Any]], LearningResult]:
    """Learn ``config`` over ``pool.train``; one row per checkpoint (``n_trials``, F1, SR)."""
    # The curve is all the experiments keep: no final refit with restarts after it.
    result = learn_from_pool(spec, pool.train, config, evaluator=evaluator,
                             eval_every=eval_every, final_fit=False)
    rows = [{"n_trials": p.n_trials, "f1": p.f1, "success_rate": p.success_rate,
             "successes": p.successes, "seed": config.seed} for p in result.curve]
    return rows, result
