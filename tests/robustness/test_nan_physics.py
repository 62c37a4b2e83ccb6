"""Diverging physics (NaN, bodies flung away) makes an invalid trial, never a crash."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from Box2D import b2

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.box2d import world as box2d_world
from ltamp_cli.backends.sanity import DivergenceGuard, PhysicsDiverged, StateLimits
from ltamp_cli.trials.collect import CollectJob, TrialInput, collect, trial_input
from ltamp_cli.trials.record import TrialDataset

Kitchen = box2d_world.Kitchen


def _first_dynamic(kitchen: Kitchen) -> b2.body:
    return next(body for body in kitchen.world.bodies if body.type == b2.dynamicBody)


def test_state_limits_name_what_is_wrong() -> None:
    limits = StateLimits(max_position=100.0, max_speed=1e3)
    fine = np.array([[1.0, 2.0], [-99.0, 0.0]])
    assert limits.violation(fine, np.zeros((2, 2))) is None
    assert limits.violation(np.array([[0.0, np.nan]]), np.zeros((1, 2)))[1].startswith(
        "non-finite position"
    )
    assert "speed" in limits.violation(fine, np.array([[0.0, 0.0], [800.0, 800.0]]))[1]
    body, what = limits.violation(np.array([[0.0, 0.0], [0.0, -150.0]]), np.zeros((2, 2)))
    assert body == 1 and "position" in what
    guard = DivergenceGuard(every=3)
    assert [guard.due() for _ in range(6)] == [False, False, True, False, False, True]
    with pytest.raises(PhysicsDiverged, match=r"non-finite velocity \(1 of 2 bodies\), first cup"):
        guard.check(fine, np.array([[0.0, 0.0], [math.inf, 0.0]]), lambda i: ["a", "cup"][i])


def test_box2d_pour_with_infinite_velocity_is_invalid() -> None:
    backend = load_backend("box2d")
    item = trial_input(backend, "pour", 0, 1, valid_only=True)
    clean = backend.run_trial("pour", item.context, item.control, item.seed)
    assert clean.valid and "reason" not in clean.info  # the guard leaves sane trials alone

    def blow_up(kitchen: Kitchen) -> None:
        if kitchen.steps == 30:
            kitchen.particles[0].linearVelocity = (math.inf, 0.0)

    result = backend.run_trial("pour", item.context, item.control, item.seed, observer=blow_up)
    assert not result.valid and result.score == -1.0
    assert result.info["reason"].startswith("physics diverged: non-finite")
    assert "after 31 steps" in result.info["reason"]  # caught at once, not after the pour


def test_box2d_push_flung_block_is_invalid() -> None:
    backend = load_backend("box2d")
    item = trial_input(backend, "push", 0, 0, valid_only=True)

    def fling(kitchen: Kitchen) -> None:
        # A runaway force (as from an exploding contact); Box2D caps each step's travel at 2
        # units, so the block leaves the world instead of going non-finite.
        if kitchen.steps >= 5:
            block = _first_dynamic(kitchen)
            block.ApplyLinearImpulse((1e9, 0.0), block.worldCenter, True)

    result = backend.run_trial("push", item.context, item.control, item.seed, observer=fling)
    assert not result.valid and result.score == -1.0
    assert "|position| > 100" in result.info["reason"]


def _sabotage(
    monkeypatch: pytest.MonkeyPatch, plan: dict[int, Callable[[Kitchen], None]]
) -> None:
    """Kitchen number ``k`` (counted as trials build them) gets observer ``plan[k]``."""
    original = Kitchen.__init__
    built = [0]

    def init(self: Kitchen, *args: object, **kwargs: object) -> None:
        original(self, *args, **kwargs)
        built[0] += 1
        if built[0] in plan:
            self.observers.append(plan[built[0]])

    monkeypatch.setattr(Kitchen, "__init__", init)


def test_collect_records_diverged_and_crashed_trials_and_goes_on(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    job = CollectJob(skill="push", backend="box2d", n=8, seed=3, valid_only=True)
    clean = {r.index: r for r in _collect(job, tmp_path / "clean.jsonl")}

    def nan_at_step_3(kitchen: Kitchen) -> None:
        if kitchen.steps == 3:
            _first_dynamic(kitchen).linearVelocity = (math.nan, 0.0)

    def raise_at_step_3(kitchen: Kitchen) -> None:
        if kitchen.steps == 3:
            raise RuntimeError("solver exploded\nwith a second line")

    _sabotage(monkeypatch, {2: nan_at_step_3, 5: raise_at_step_3})
    records = _collect(job, tmp_path / "sabotaged.jsonl")
    assert sorted(r.index for r in records) == list(range(8))  # collection went on
    broken = {r.index: r.info["reason"] for r in records if not r.valid}
    assert len(broken) == 2 and all(records[i].score == -1.0 for i in broken)
    reasons = sorted(broken.values())
    assert reasons[0].startswith("physics diverged: non-finite")
    assert reasons[1] == "trial raised RuntimeError: solver exploded with a second line"
    for record in records:  # every other trial is exactly what a clean run gives
        if record.index not in broken:
            assert (record.score, record.valid) == (
                clean[record.index].score,
                clean[record.index].valid,
            )


def _collect(job: CollectJob, out: Path) -> list:
    assert collect(job, out, workers=1, progress=False) == job.n
    return sorted(TrialDataset(out).read(), key=lambda r: r.index)


def _inject_after(
    monkeypatch: pytest.MonkeyPatch, world_class: type, at_step: int, act: Callable[..., None]
) -> None:
    """``act(world)`` right after the world's ``at_step``-th ``step`` call."""
    original = world_class.step
    calls = [0]

    def step(self: object, n: int = 1) -> None:
        original(self, n)
        calls[0] += 1
        if calls[0] == at_step:
            act(self)

    monkeypatch.setattr(world_class, "step", step)


def _valid_pour(backend: object) -> TrialInput:
    """The first uniformly drawn pour trial whose control is valid (``valid_only`` draws
    hundreds of candidates, which costs seconds on the 3D backends)."""
    for index in range(100):
        item = trial_input(backend, "pour", 0, index)
        if backend.is_valid("pour", item.context, item.control[None])[0]:
            return item
    raise AssertionError("no valid pour among 100 draws")


def _bead_ids(client: int) -> list[int]:
    import pybullet as p

    ids = [p.getBodyUniqueId(i, physicsClientId=client)
           for i in range(p.getNumBodies(physicsClientId=client))]  # fmt: skip
    return [i for i in ids if p.getDynamicsInfo(i, -1, physicsClientId=client)[0] > 0]


@pytest.mark.slow  # three PyBullet pours (~4 s CPU)
def test_pybullet_pour_with_nan_or_flung_bead_is_invalid(monkeypatch: pytest.MonkeyPatch) -> None:
    import pybullet as p

    from ltamp_cli.backends.pybullet.world import PhysicsWorld

    def infinite_velocity(world: PhysicsWorld) -> None:
        bead = _bead_ids(world.client)[-1]
        p.resetBaseVelocity(bead, [math.inf, 0.0, 0.0], physicsClientId=world.client)

    def flung(world: PhysicsWorld) -> None:
        # Bullet caps multibody speeds (100 m/s), so a runaway bead shows as a far position.
        bead = _bead_ids(world.client)[-1]
        p.resetBasePositionAndOrientation(
            bead, [500.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0], physicsClientId=world.client
        )

    backend = load_backend("pybullet")
    try:
        item = _valid_pour(backend)
        clean = backend.run_trial("pour", item.context, item.control, item.seed)
        assert clean.valid and "reason" not in clean.info
        reasons = []
        for kick in (infinite_velocity, flung):
            with monkeypatch.context() as patch:
                _inject_after(patch, PhysicsWorld, 50, kick)
                result = backend.run_trial("pour", item.context, item.control, item.seed)
            assert not result.valid and result.score == -1.0
            reasons.append(result.info["reason"])
        # The world is reset per trial: a diverged trial leaves nothing behind.
        assert backend.run_trial("pour", item.context, item.control, item.seed) == clean
    finally:
        backend.close()
    assert reasons[0].startswith("physics diverged: non-finite")
    assert reasons[1].startswith("physics diverged: |position| > 100 (1 of")


def test_sapien_pour_with_nan_or_too_fast_bead_is_invalid(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    pytest.importorskip("sapien")
    from ltamp_cli.backends.sapien.world import SapienWorld

    backend = load_backend("sapien")
    try:
        item = _valid_pour(backend)
        clean = backend.run_trial("pour", item.context, item.control, item.seed)
        assert clean.valid and "reason" not in clean.info
        reasons = []
        for speed in (math.inf, 5e3):

            def kick(world: SapienWorld, speed: float = speed) -> None:
                bead = world.scene.physx_system.get_rigid_dynamic_components()[-1]
                bead.set_linear_velocity([speed, 0.0, 0.0])

            with monkeypatch.context() as patch:
                _inject_after(patch, SapienWorld, 50, kick)
                result = backend.run_trial("pour", item.context, item.control, item.seed)
            assert not result.valid and result.score == -1.0
            reasons.append(result.info["reason"])
        assert backend.run_trial("pour", item.context, item.control, item.seed) == clean
    finally:
        backend.close()
    assert reasons[0].startswith("physics diverged: non-finite")
    # Which limit trips first depends on when the guard's rotating slice reaches the kicked
    # bead: by then it may already be 100 m away. Either names the bead and invalidates.
    assert reasons[1].startswith(("physics diverged: speed > 1000",
                                  "physics diverged: |position| > 100"))
    assert all("first bead" in reason for reason in reasons)


def test_collect_marks_non_finite_results_invalid(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ltamp_cli.backends.protocol import TrialResult
    from ltamp_cli.backends.synthetic import SyntheticBackend
    from ltamp_cli.trials.collect import trial_seed

    original = SyntheticBackend.run_trial
    seed_of = {trial_seed(7, index): index for index in range(6)}

    def run_trial(
        self: SyntheticBackend, skill: str, context: np.ndarray, control: np.ndarray, seed: int
    ) -> TrialResult:
        index = seed_of[seed]
        if index == 1:
            return TrialResult(math.nan, True, {})
        if index == 2:
            return TrialResult(0.5, True, {"fraction": math.inf})
        if index == 3:
            raise FloatingPointError("overflow in the integrator")
        return original(self, skill, context, control, seed)

    monkeypatch.setattr(SyntheticBackend, "run_trial", run_trial)
    job = CollectJob(skill="toy1d", backend="synthetic", n=6, seed=7)
    records = _collect(job, tmp_path / "t.jsonl")
    assert [r.valid for r in records] == [True, False, False, False, True, True]
    assert [r.score for r in records[1:4]] == [-1.0, -1.0, -1.0]
    assert records[1].info["reason"] == "non-finite score nan"
    assert records[2].info["reason"].startswith("unrecordable trial info")
    assert records[3].info["reason"] == (
        "trial raised FloatingPointError: overflow in the integrator"
    )


def test_online_learning_records_a_raising_trial_and_goes_on(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from ltamp_cli.backends.synthetic import SyntheticBackend
    from ltamp_cli.learning.active import LearningConfig, learn_online

    original = SyntheticBackend.run_trial
    calls = [0]

    def run_trial(
        self: SyntheticBackend, skill: str, context: np.ndarray, control: np.ndarray, seed: int
    ) -> object:
        calls[0] += 1
        if calls[0] == 3:
            raise ZeroDivisionError("mass ratio")
        return original(self, skill, context, control, seed)

    monkeypatch.setattr(SyntheticBackend, "run_trial", run_trial)
    dataset = TrialDataset(tmp_path / "trials.jsonl")
    config = LearningConfig(strategy="random", budget=6, init=2, seed=0)
    result = learn_online(load_backend("synthetic"), "moving2d", config, dataset)
    records = dataset.read()
    assert [r.index for r in records] == list(range(6)) and len(result.records) == 6
    assert [r.valid for r in records].count(False) == 1
    assert not records[2].valid and records[2].score == -1.0
    assert records[2].info["reason"] == "trial raised ZeroDivisionError: mass ratio"
