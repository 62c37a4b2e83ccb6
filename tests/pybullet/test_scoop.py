"""Scoop trials on the PyBullet Kitchen3D backend: score, validity, spoon path."""

from __future__ import annotations

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.kitchenware_geometry import SpoonDims, spoon_geometry
from ltamp_cli.backends.protocol import SkillBackend
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial
from ltamp_cli.backends.pybullet.particles import BeadSpec
from ltamp_cli.backends.pybullet.skills.physics import BulletTrialPhysics
from ltamp_cli.backends.pybullet.skills.scoop import (
    NOMINAL_BOWL,
    SCOOP_CONTEXT,
    SCOOP_TAU,
    ScoopContext,
    measure_spoon_capacity,
    scoop_outcome,
    scoop_path,
)
from ltamp_cli.backends.pybullet.world import PhysicsWorld

CONTEXT = ScoopContext(NOMINAL_BOWL, SpoonDims(0.2)).to_array()
# Drag low through the heap from +y to -y, lift out over the centre (seeds 0-2: 18/20,
# 18/21 and 15/21 of the measured capacity).
GOOD = np.array([0.25, -0.05, 0.0, -0.015, 0.02])
# No drag and 4 cm above the floor: the spoon dips and comes straight out.
BAD = np.array([0.0, 0.0, 0.0, 0.02, 0.03])
# Drag below the bowl's floor.
THROUGH_FLOOR = np.array([0.1, -0.1, 0.0, -0.02, 0.02])
# Start at the rim: the head hits the wall on the way down.
AT_RIM = np.array([0.5, -0.1, 0.0, 0.0, 0.02])


@pytest.fixture(scope="module")
def backend() -> SkillBackend:
    backend = load_backend("pybullet")
    yield backend
    backend.close()


def test_measured_capacity_grows_with_the_spoon() -> None:
    material = BodyMaterial(mass=0.05)
    with PhysicsWorld() as world:
        physics = BulletTrialPhysics(world)

        def capacity(length: float, radius: float) -> int:
            spec = BeadSpec(count=1, radius=radius, mass=0.001)
            return measure_spoon_capacity(physics, spoon_geometry(SpoonDims(length)), spec,
                                          material, np.random.default_rng(0), 0.5)

        small, large = capacity(0.16, 0.006), capacity(0.24, 0.006)
        # The old computed capacity (half the cavity's volume in beads) was 13 for 0.2 m.
        assert 10 <= small < large <= 100
        assert capacity(0.24, 0.006) == large  # deterministic given the rng


def test_fraction_of_capacity_is_reported_uncapped() -> None:
    over = scoop_outcome(10, 250, 250, 12, 0, 0.006, 100, 1 / 240)
    assert over.info["fraction_of_capacity"] == pytest.approx(1.2)
    assert over.score == 1.0
    under = scoop_outcome(20, 250, 250, 7, 0, 0.006, 100, 1 / 240)
    assert under.info["fraction_of_capacity"] == pytest.approx(0.35) and under.score < 0


def test_scoop_path_waypoints() -> None:
    path = scoop_path(ScoopContext.from_array(CONTEXT), GOOD)
    assert len(path) == 4
    d = NOMINAL_BOWL.top_diameter
    assert np.allclose(path.positions[:, 1], [0.25 * d, 0.25 * d, -0.05 * d, 0.0])
    assert path.positions[1, 2] == pytest.approx(path.positions[2, 2])  # level drag
    assert path.positions[0, 2] > NOMINAL_BOWL.height  # entry above the rim
    assert path.positions[3, 2] == pytest.approx(NOMINAL_BOWL.height + 0.02)
    assert np.allclose(path.quaternions[3], [0.0, 0.0, 0.0, 1.0])  # upright at the exit


def test_invalid_scoops_are_rejected_without_simulating(
    backend: SkillBackend, monkeypatch: pytest.MonkeyPatch
) -> None:
    def no_physics(*_: object, **__: object) -> None:
        raise AssertionError("an invalid control was simulated")

    monkeypatch.setattr(PhysicsWorld, "step", no_physics)
    monkeypatch.setattr(PhysicsWorld, "reset", no_physics)
    batch = np.stack([GOOD, THROUGH_FLOOR, AT_RIM, BAD])
    assert backend.is_valid("scoop", CONTEXT, batch).tolist() == [True, False, False, True]
    for control in (THROUGH_FLOOR, AT_RIM):
        result = backend.run_trial("scoop", CONTEXT, control, seed=0)
        assert not result.valid and result.score == -1.0
        assert "bowl" in result.info["reason"]


def test_sampled_contexts_lie_in_the_context_box(backend: SkillBackend) -> None:
    rng = np.random.default_rng(1)
    contexts = np.stack([backend.sample_context("scoop", rng) for _ in range(200)])
    assert np.all(contexts >= SCOOP_CONTEXT.low_array() - 1e-12)
    assert np.all(contexts <= SCOOP_CONTEXT.high_array() + 1e-12)


@pytest.mark.parametrize("seed", [0, 1])
def test_known_good_scoop_fills_the_spoon(backend: SkillBackend, seed: int) -> None:
    result = backend.run_trial("scoop", CONTEXT, GOOD, seed=seed)
    assert result.valid and result.score > 0, result.info
    assert result.info["fraction_of_capacity"] > SCOOP_TAU
    assert result.info["beads_lost"] == 0
    assert result.info["beads_in_bowl_start"] == result.info["beads_total"]


def test_known_bad_scoop_fails(backend: SkillBackend) -> None:
    result = backend.run_trial("scoop", CONTEXT, BAD, seed=0)
    assert result.valid and result.score < 0, result.info
    assert result.info["beads_lost"] == 0
