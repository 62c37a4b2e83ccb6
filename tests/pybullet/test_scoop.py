"""Scoop trials on the PyBullet Kitchen3D backend: score, validity, spoon path."""

from __future__ import annotations

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.kitchenware_geometry import SpoonDims, VesselDims, spoon_geometry
from ltamp_cli.backends.protocol import SkillBackend
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial
from ltamp_cli.backends.pybullet.particles import BeadSpec
from ltamp_cli.backends.pybullet.skills.physics import BulletTrialPhysics
from ltamp_cli.backends.pybullet.skills.scoop import (
    MAX_FILL_FRACTION,
    MIN_BED_DEPTH_M,
    NOMINAL_BOWL,
    SCOOP_CONTEXT,
    SCOOP_TAU,
    ScoopContext,
    ScoopSettings,
    bed_depth_m,
    measure_spoon_capacity,
    sample_scoop_latents,
    scoop_bead_count,
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


# The widest bowl of the context box and a narrow one (bowl top, height, base; spoon).
WIDE = np.array([0.25, 0.1, 0.1875, 0.2])
NARROW = np.array([0.166, 0.089, 0.098, 0.2])


def test_bed_is_raised_to_the_references_depth_in_wide_bowls_only() -> None:
    wide = ScoopContext.from_array(WIDE).bowl
    count = scoop_bead_count(wide, 250, 0.006)
    # 250 beads lie ~17 mm deep here (the reference dropped such bowls): raised to the
    # fewest beads that make a 25 mm bed.
    assert bed_depth_m(wide, 250, 0.006) < 0.02
    assert count > 400
    assert bed_depth_m(wide, count, 0.006) >= MIN_BED_DEPTH_M - 1e-6
    assert bed_depth_m(wide, count - 1, 0.006) < MIN_BED_DEPTH_M
    # Deep enough already: the drawn count is kept.
    narrow = ScoopContext.from_array(NARROW).bowl
    assert bed_depth_m(narrow, 250, 0.006) > MIN_BED_DEPTH_M
    assert scoop_bead_count(narrow, 250, 0.006) == 250


def test_bed_never_rises_above_three_quarters_of_the_bowl() -> None:
    small = VesselDims(base_diameter=0.05, top_diameter=0.08, height=0.05)
    count = scoop_bead_count(small, 300, 0.006)
    top = MAX_FILL_FRACTION * small.height - small.thickness
    assert count < 300
    assert bed_depth_m(small, count, 0.006) <= top + 1e-9
    assert bed_depth_m(small, count + 1, 0.006) > top


def test_bead_draws_do_not_depend_on_the_bowl() -> None:
    # Same seed: same radius and materials in every bowl, only the count follows the bowl,
    # so a deep-enough bowl's trial is the one it was before the bed rule.
    settings = ScoopSettings()
    wide = sample_scoop_latents(np.random.default_rng(3), settings,
                                ScoopContext.from_array(WIDE).bowl)
    narrow = sample_scoop_latents(np.random.default_rng(3), settings,
                                  ScoopContext.from_array(NARROW).bowl)
    assert wide.beads.radius == narrow.beads.radius
    assert wide.spoon_material == narrow.spoon_material
    assert wide.beads.count > narrow.beads.count


def test_a_wide_bowl_holds_the_whole_raised_bed(backend: SkillBackend) -> None:
    result = backend.run_trial("scoop", WIDE, BAD, seed=0)
    bowl = ScoopContext.from_array(WIDE).bowl
    latents = sample_scoop_latents(np.random.default_rng(0), ScoopSettings(), bowl)
    assert result.valid, result.info
    assert result.info["beads_total"] == latents.beads.count > 300
    assert result.info["beads_in_bowl_start"] == result.info["beads_total"]
