"""A pooled experiment's job resumes *inside* itself (issue #21): its evaluated checkpoints
are logged as they finish, and a rerun of an interrupted job reads them back, continues the
live trials' seeds where they stopped, and records byte-for-byte the job an uninterrupted run
records."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bench.paper import supervised3d
from bench.paper.common import CheckpointLog, Context, LiveScore
from bench.paper.poollearn import CheckpointEvaluator, memoized_validity, theta_validity
from ltamp_cli.backends import load_backend
from ltamp_cli.backends.synthetic import SyntheticBackend
from ltamp_cli.learning.active import LearningConfig, learn_online

# Three checkpoints, each simulating θ* on 3 contexts; two learners (a GP, whose fits warm-start
# from the last one, and a network), one seed, no kernel-only jobs: 2 jobs x 3 checkpoints.
TINY = {**supervised3d.SIZES["smoke"], "budget": 30, "eval_every": 10,
        "success_at": [10, 20, 30]}
LEARNERS = [("gp", "mlp"), ("nn-c", "matern52")]


class Interrupted(Exception):
    """Stands for the end of a session (a kill between two checkpoints)."""


@pytest.fixture
def tiny(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, int]]:
    """The tiny sizes; returns the list every simulated trial's (skill, seed) is added to
    (the pool's, then θ*'s)."""
    monkeypatch.setitem(supervised3d.SIZES, "smoke", TINY)
    monkeypatch.setattr(supervised3d, "LEARNERS", LEARNERS)
    monkeypatch.setattr(supervised3d, "KERNELS", ["mlp"])
    seeds: list[tuple[str, int]] = []
    original = SyntheticBackend.run_trial

    def run_trial(self: SyntheticBackend, skill: str, context: Any, control: Any,
                  seed: int) -> Any:
        seeds.append((skill, seed))
        return original(self, skill, context, control, seed)

    monkeypatch.setattr(SyntheticBackend, "run_trial", run_trial)
    return seeds


def _run(out: Path) -> Path:
    ctx = Context("smoke", out, False, 1)
    supervised3d.run_part(ctx, "skill8d")
    return out / "runs" / "supervised3d-smoke.jsonl"


@pytest.mark.slow
def test_interrupted_job_resumes_to_identical_records(
        tiny: list[tuple[str, int]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    whole = _run(tmp_path / "whole").read_bytes()
    assert whole.count(b"\n") == 2
    uninterrupted_seeds = tiny[-2 * 3 * 3:]  # after the pool's trials: the θ* trials

    # Interrupt the second job right after its second checkpoint is logged.
    tiny.clear()
    put = CheckpointLog.put
    calls = {"n": 0}

    def interrupting_put(self: CheckpointLog, key: str, entry: dict[str, Any]) -> Any:
        stored = put(self, key, entry)
        calls["n"] += 1
        if calls["n"] == 5:
            raise Interrupted
        return stored

    monkeypatch.setattr(CheckpointLog, "put", interrupting_put)
    with pytest.raises(Interrupted):
        _run(tmp_path / "resumed")
    log = tmp_path / "resumed" / "runs" / "supervised3d-smoke.jsonl"
    assert log.read_bytes().count(b"\n") == 1  # the first job only
    monkeypatch.setattr(CheckpointLog, "put", put)

    evaluated: list[int] = []
    evaluate = CheckpointEvaluator.evaluate

    def counting(self: CheckpointEvaluator, model: Any, n_trials: int,
                 success: bool = True) -> Any:
        if n_trials not in self.logged:
            evaluated.append(n_trials)
        return evaluate(self, model, n_trials, success)

    monkeypatch.setattr(CheckpointEvaluator, "evaluate", counting)
    before_rerun = len(tiny)
    assert _run(tmp_path / "resumed").read_bytes() == whole
    # Only the missing checkpoint was evaluated again, with the trial seeds an uninterrupted
    # run gives it (the logged checkpoints' 6 trials were skipped, not rerun).
    assert evaluated == [30]
    assert tiny[before_rerun:] == uninterrupted_seeds[-3:]
    assert tiny[before_rerun - 15:before_rerun] == uninterrupted_seeds[:-3]


def test_checkpoint_log_round_trip_and_other_sizes(tmp_path: Path) -> None:
    ctx = Context("smoke", tmp_path, False, 1)
    log = CheckpointLog(ctx, "exp", {"seeds": 1})
    entry = {"n_trials": 10, "f1": 0.1 + 0.2, "success_rate": 2 / 3,
             "successes": [True, False, True], "scorer": 3}
    log.put("a/0", entry)
    with log.path.open("a") as handle:
        handle.write('{"key": "a/0", "n_tri')  # torn by an interruption
    again = CheckpointLog(ctx, "exp", {"seeds": 1})
    assert again.get("a/0")[10]["f1"] == 0.1 + 0.2
    assert again.get("a/0")[10]["successes"] == [True, False, True]
    assert again.get("b/0") == {}
    assert CheckpointLog(ctx, "exp", {"seeds": 2}).get("a/0") == {}
    again.put("a/0", {**entry, "n_trials": 20})  # after the torn line, on a line of its own
    assert set(CheckpointLog(ctx, "exp", {"seeds": 1}).get("a/0")) == {10, 20}


def test_replayed_checkpoint_moves_the_scorer_past_its_trials() -> None:
    class Backend:
        def run_trial(self, skill: str, context: Any, control: Any, seed: int) -> Any:
            raise AssertionError("a logged checkpoint must not simulate")

    scorer = LiveScore(Backend(), "pour", 500)  # type: ignore[arg-type]
    from ltamp_cli.backends.synthetic import make_backend

    spec = make_backend().skills()["skill8d"]
    entry = {"n_trials": 10, "f1": 0.5, "success_rate": 1.0, "successes": [True], "scorer": 45}
    evaluator = CheckpointEvaluator(spec, None, scorer, np.zeros((1, spec.context.dim)), None,
                                    {10}, 0, 10, logged={10: entry})
    result = evaluator.evaluate(None, 10)  # type: ignore[arg-type]
    assert (result.f1, result.success_rate, result.successes) == (0.5, 1.0, (True,))
    assert scorer.position == 45


def test_memoized_validity_asks_each_control_once() -> None:
    asked: list[int] = []

    def is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        asked.append(len(controls))
        return controls[:, 0] > 0.0

    test = memoized_validity(is_valid, limit=6)
    controls = np.array([[1.0], [-1.0], [2.0]])
    assert test(np.zeros(2), controls).tolist() == [True, False, True]
    assert test(np.zeros(2), controls[::-1]).tolist() == [True, False, True]
    assert test(np.ones(2), controls[:1]).tolist() == [True]  # another context: asked
    assert asked == [3, 1]
    test(np.full(2, 2.0), np.array([[3.0], [4.0], [-5.0]]))  # over the limit: starts afresh
    assert test(np.zeros(2), controls[:1]).tolist() == [True] and asked == [3, 1, 3, 1]


@pytest.mark.parametrize("strategy", ["gp", "nn-c", "rf-r"])
def test_theta_validity_gives_the_full_tests_theta_with_fewer_checks(strategy: str) -> None:
    backend = load_backend("synthetic")
    calls = {"full": 0, "theta": 0}

    def counted(name: str) -> Any:
        def test(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
            calls[name] += len(controls)
            return backend.is_valid("skill8d", context, controls)
        return test

    model = learn_online(backend, "skill8d",
                         LearningConfig(strategy=strategy, budget=20, seed=1)).model
    theta = theta_validity(memoized_validity(counted("theta")), strategy)
    rng = np.random.default_rng(5)
    for index in range(5):
        context = backend.sample_context("skill8d", rng)
        for _ in range(2):  # a second checkpoint with the same candidates: remembered
            a, _ = model.most_confident_control(context, np.random.default_rng(index),
                                                counted("full"), 2000)
            b, _ = model.most_confident_control(context, np.random.default_rng(index), theta,
                                                2000)
            np.testing.assert_array_equal(a, b)
    assert calls["theta"] < calls["full"] / 8
    backend.close()


@pytest.mark.parametrize("name", ["supervised3d", "active3d"])
def test_committed_standard_job_logs_still_match_their_sizes(name: str) -> None:
    """The committed standard job logs are read back (same sizes hash), so their jobs are not
    rerun: the checkpoint log added nothing to what a job's hash depends on."""
    import importlib
    import json

    from bench.paper.common import REPO, sizes_hash
    from bench.paper.poollearn import job_sizes

    module = importlib.import_module(f"bench.paper.{name}")
    sizes = Context("standard", REPO / "docs" / "results" / "standard", False).sizes(
        module.SIZES)
    log = REPO / "docs" / "results" / "standard" / "runs" / f"{module.NAME}-standard.jsonl"
    lines = [json.loads(line) for line in log.read_text().splitlines()]
    assert lines and {line["sizes"] for line in lines} == {
        sizes_hash(job_sizes(sizes, skill)) for skill in sizes["skills"]}
