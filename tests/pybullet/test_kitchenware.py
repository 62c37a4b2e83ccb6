"""Procedural kitchenware: geometry of the convex pieces and real PyBullet contacts."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from ltamp_cli.backends.kitchenware_geometry import (
    SpoonDims,
    VesselDims,
    block_geometry,
    faucet_geometry,
    points_in_vessel_wall,
    spoon_geometry,
    stirrer_geometry,
    vessel_geometry,
)
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial, create_kitchenware
from ltamp_cli.backends.pybullet.world import PhysicsWorld

BOWL = VesselDims(base_diameter=0.12, top_diameter=0.2, height=0.08, thickness=0.004)


def frustum_volume(r0: float, r1: float, h: float) -> float:
    return math.pi * h / 3.0 * (r0 * r0 + r0 * r1 + r1 * r1)


def test_vessel_pieces_are_convex_and_volume_matches_the_revolved_shell() -> None:
    geometry = vessel_geometry(BOWL, segments=32)
    assert len(geometry.pieces) == 33
    assert all(piece.shape[1] == 3 for piece in geometry.pieces)
    assert all(hull.is_convex and hull.volume > 0 for hull in geometry.hulls())
    t = BOWL.thickness
    wall = frustum_volume(BOWL.base_radius, BOWL.top_radius, BOWL.height) - frustum_volume(
        BOWL.base_radius - t, BOWL.top_radius - t, BOWL.height
    )
    base = math.pi * BOWL.base_radius**2 * t
    # Sector chords cut the outer circle and bulge into the inner one by about as much.
    assert geometry.volume() == pytest.approx(wall + base, rel=0.03)
    low, high = geometry.bounds()
    assert low[2] == pytest.approx(0.0) and high[2] == pytest.approx(BOWL.height)
    assert high[0] == pytest.approx(BOWL.top_radius, rel=1e-9)


def test_wall_test_separates_material_from_cavity_and_outside() -> None:
    mid_wall = np.array([[BOWL.top_radius - 0.002, 0.0, BOWL.height - 0.001]])
    base = np.array([[0.01, 0.02, 0.002]])
    cavity = np.array([[0.0, 0.0, 0.04]])
    outside = np.array([[0.2, 0.0, 0.04]])
    points = np.concatenate([mid_wall, base, cavity, outside])
    assert points_in_vessel_wall(points, BOWL).tolist() == [True, True, False, False]
    # A margin reaches points just outside the wall.
    near = np.array([[BOWL.top_radius + 0.003, 0.0, BOWL.height / 2]])
    near_r = float(BOWL.outer_radius_at(BOWL.height / 2)) + 0.003
    near[0, 0] = near_r
    assert not points_in_vessel_wall(near, BOWL, margin=0.0)[0]
    assert points_in_vessel_wall(near, BOWL, margin=0.005)[0]


def test_bad_dimensions_are_rejected() -> None:
    with pytest.raises(ValueError, match="positive"):
        VesselDims(0.1, -0.2, 0.1)
    with pytest.raises(ValueError, match="thickness"):
        VesselDims(0.01, 0.01, 0.1, thickness=0.004)
    with pytest.raises(ValueError, match="spoon length"):
        SpoonDims(2.0)


def test_other_kitchenware_has_the_requested_size() -> None:
    spoon = spoon_geometry(SpoonDims(0.2))
    extent = spoon.bounds()[1] - spoon.bounds()[0]
    assert 0.15 < float(np.hypot(extent[1], extent[2])) < 0.25
    assert spoon.cavity is not None and spoon.vessel is not None
    assert stirrer_geometry(0.2).bounds()[1, 2] == pytest.approx(0.2)
    assert np.allclose(block_geometry((0.04, 0.05, 0.06)).bounds()[1], [0.02, 0.025, 0.06])
    faucet = faucet_geometry(height=0.3, reach=0.2)
    assert faucet.bounds()[1, 0] == pytest.approx(0.2) and faucet.bounds()[1, 2] == pytest.approx(
        0.3
    )


def drop_sphere(world: PhysicsWorld, xy: tuple[float, float], radius: float = 0.01) -> float:
    shape = p.createCollisionShape(p.GEOM_SPHERE, radius=radius, physicsClientId=world.client)
    ball = p.createMultiBody(0.01, shape, -1, [xy[0], xy[1], 0.15], physicsClientId=world.client)
    world.step(world.steps_for(1.0))
    return p.getBasePositionAndOrientation(ball, physicsClientId=world.client)[0][2]


def test_bowl_body_holds_a_ball_and_the_table_catches_one_outside() -> None:
    with PhysicsWorld() as world:
        create_kitchenware(world.client, vessel_geometry(BOWL), material=BodyMaterial(mass=0.0))
        inside = drop_sphere(world, (0.0, 0.0))
        outside = drop_sphere(world, (0.3, 0.0))
    assert inside == pytest.approx(BOWL.thickness + 0.01, abs=0.002)
    assert outside == pytest.approx(0.01, abs=0.002)


def test_two_worlds_are_independent_clients() -> None:
    with PhysicsWorld() as first, PhysicsWorld() as second:
        assert first.client != second.client
        cup = create_kitchenware(first.client, vessel_geometry(BOWL, "cup"), (0.5, 0.0, 0.0))
        assert p.getNumBodies(physicsClientId=first.client) == 2
        assert p.getNumBodies(physicsClientId=second.client) == 1
        position, _ = cup.pose()
        assert np.allclose(position, [0.5, 0.0, 0.0], atol=1e-9)


def test_dynamic_body_pose_is_the_object_frame_not_the_centre_of_mass() -> None:
    with PhysicsWorld() as world:
        cup = create_kitchenware(world.client, vessel_geometry(BOWL, "cup"), (0.0, 0.0, 0.3))
        assert any(abs(v) > 0 for v in cup.com_offset)
        tilt = p.getQuaternionFromEuler([0.0, -1.0, 0.0])
        cup.set_pose((0.1, 0.2, 0.3), tilt)
        position, orientation = cup.pose()
    assert np.allclose(position, [0.1, 0.2, 0.3], atol=1e-9)
    assert np.allclose(orientation, tilt, atol=1e-9)
