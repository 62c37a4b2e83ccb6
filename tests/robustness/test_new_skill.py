"""A skill ltamp has never seen, added through the Python API as the docs describe (a
``SkillBackend`` with its own score function): trained, saved and reloaded, sampled, and
planned with through a learned stream.

The ``throw`` skill: throw a ball (speed m/s, angle rad) so that it lands within 0.4 m of a
target distance (context, m). Range ``v² sin 2a / g`` with 2 % multiplicative noise; a
throw whose horizontal speed exceeds 8.5 m/s is invalid (the arm cannot), scored
``invalid_score``. Success is rare under uniform controls (about 6 % of the valid box at a
5 m target), so the learned set must do much better than chance.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.backends.protocol import ParamSpace, SkillSpec, TrialResult
from ltamp_cli.learned_streams.stream import LearnedStream, LearnedStreamConfig
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.pddlstream import PDDLProblem, from_gen_fn, from_test, solve
from ltamp_cli.sampling.factory import make_sampler
from ltamp_cli.trials.record import TrialDataset

GRAVITY = 9.81
TOLERANCE = 0.4


class ThrowBackend:
    """Throw a ball to a target distance (a backend written from scratch for this test)."""

    name = "throw-test"

    def __init__(self) -> None:
        self._spec = SkillSpec(
            name="throw",
            context=ParamSpace(("target",), (2.0,), (8.0,)),
            control=ParamSpace(("speed", "angle"), (0.0, 0.1), (10.0, 1.45)),
            description="throw a ball to land within 0.4 m of a target distance")

    def skills(self) -> dict[str, SkillSpec]:
        return {"throw": self._spec}

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        return self._spec.context.sample_uniform(rng, 1)[0]

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        controls = np.atleast_2d(controls)
        return controls[:, 0] * np.cos(controls[:, 1]) <= 8.5

    def run_trial(self, skill: str, context: np.ndarray, control: np.ndarray,
                  seed: int) -> TrialResult:
        if not self.is_valid(skill, context, control[None, :])[0]:
            return TrialResult(self._spec.invalid_score, False, {"reason": "too fast"})
        noise = 1.0 + 0.02 * np.random.default_rng(seed).standard_normal()
        landing = throw_range(control) * noise
        return TrialResult(TOLERANCE - abs(landing - float(context[0])), True,
                           {"landing_m": landing})

    def close(self) -> None:
        pass


def throw_range(control: np.ndarray) -> float:
    speed, angle = float(control[0]), float(control[1])
    return speed**2 * math.sin(2 * angle) / GRAVITY


def wilson_low(successes: int, n: int, z: float = 1.96) -> float:
    p = successes / n
    centre = p + z * z / (2 * n)
    margin = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return (centre - margin) / (1 + z * z / n)


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("throw")
    backend = ThrowBackend()
    result = learn_online(backend, "throw", LearningConfig(budget=60, init=15, seed=0),
                          TrialDataset(folder / "trials.jsonl"))
    assert len(result.records) == 60
    result.model.save(str(folder / "model"), backend=backend.name, strategy="lse")
    return folder / "model"


def test_reloaded_model_samples_successful_throws(trained: Path) -> None:
    model = load_model(trained).model
    backend = ThrowBackend()
    rng = np.random.default_rng(1)
    successes = total = 0
    for target in (3.0, 5.0, 7.0):
        context = np.array([target])
        sampler = make_sampler("adaptive", model, context, rng,
                               is_valid=lambda c, u: backend.is_valid("throw", c, u))
        for index in range(10):
            control = next(sampler)
            result = backend.run_trial("throw", context, control, seed=1000 + index)
            successes += int(result.valid and result.score > 0)
            total += 1
    # uniform valid controls succeed ~6 % of the time at 5 m; require the lower end of the
    # 95 % Wilson interval of the learned sampler's rate to be above 0.4
    assert wilson_low(successes, total) > 0.4, (successes, total)


def test_random_throws_rarely_succeed() -> None:
    """The baseline the previous test beats (so its threshold means something)."""
    backend = ThrowBackend()
    spec = backend.skills()["throw"]
    rng = np.random.default_rng(2)
    controls = spec.control.sample_uniform(rng, 2000)
    context = np.array([5.0])
    valid = backend.is_valid("throw", context, controls)
    hits = [backend.run_trial("throw", context, c, seed=i).score > 0
            for i, c in enumerate(controls[valid])]
    assert np.mean(hits) < 0.15


DOMAIN = """
(define (domain throwing)
  (:requirements :strips)
  (:predicates (Target ?d) (Throw ?d ?c) (Lands ?d ?c) (Scored ?d))
  (:action throw
    :parameters (?d ?c)
    :precondition (and (Throw ?d ?c) (Lands ?d ?c))
    :effect (Scored ?d)))
"""
STREAMS = """
(define (stream throwing)
  (:stream sample-throw :inputs (?d) :domain (Target ?d)
    :outputs (?c) :certified (Throw ?d ?c))
  (:stream test-lands :inputs (?d ?c) :domain (Throw ?d ?c) :certified (Lands ?d ?c)))
"""


def test_plan_with_the_learned_skill(trained: Path) -> None:
    learned = LearnedStream(LearnedStreamConfig(model_dir=trained),
                            to_context=lambda target: np.array([float(target)]),
                            to_outputs=lambda control, target: (tuple(map(float, control)),),
                            rng=np.random.default_rng(3))

    def lands(target: float, control: tuple[float, float]) -> bool:
        return abs(throw_range(np.array(control)) - float(target)) <= TOLERANCE

    problem = PDDLProblem(DOMAIN, {}, STREAMS,
                          {"sample-throw": from_gen_fn(learned), "test-lands": from_test(lands)},
                          [("Target", 3.5), ("Target", 6.5)],
                          ("and", ("Scored", 3.5), ("Scored", 6.5)))
    solution = solve(problem, algorithm="adaptive", max_time=60, verbose=False)
    assert solution.plan is not None
    assert sorted(step.args[0] for step in solution.plan) == [3.5, 6.5]
    for step in solution.plan:
        assert lands(*step.args)
