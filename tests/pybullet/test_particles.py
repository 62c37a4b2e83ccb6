"""Beads: spawning inside a vessel, containment counting and conservation under physics."""

from __future__ import annotations

import numpy as np
import pybullet as p

from ltamp_cli.backends.kitchenware_geometry import ContainmentPrism, VesselDims, vessel_geometry
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial, create_kitchenware
from ltamp_cli.backends.pybullet.particles import (
    BeadSpec,
    bead_positions,
    contained_mask,
    count_contained,
    count_lost,
    grid_in_vessel,
    spawn_beads_in,
)
from ltamp_cli.backends.pybullet.world import PhysicsWorld

BOWL = VesselDims(base_diameter=0.12, top_diameter=0.2, height=0.08)


def test_grid_fills_the_cavity_without_overlaps() -> None:
    spec = BeadSpec(count=150, radius=0.006)
    points = grid_in_vessel(BOWL, spec, np.random.default_rng(0))
    assert points.shape == (150, 3)
    radius = np.hypot(points[:, 0], points[:, 1])
    inner = BOWL.outer_radius_at(np.minimum(points[:, 2], BOWL.height)) - BOWL.thickness
    assert np.all(radius + spec.radius <= inner)
    assert np.all(points[:, 2] - spec.radius > BOWL.thickness)
    gaps = np.linalg.norm(points[:, None] - points[None], axis=2) + np.eye(len(points))
    assert gaps.min() > 2 * spec.radius


def test_prism_counts_in_the_container_frame() -> None:
    prism = ContainmentPrism((-0.1, -0.1, 0.0), (0.1, 0.1, 0.1))
    points = np.array([[0.0, 0.0, 0.05], [0.0, 0.0, 0.15], [0.11, 0.0, 0.05]])
    assert prism.contains(points).tolist() == [True, False, False]


def test_beads_are_conserved_and_counted_per_container() -> None:
    rng = np.random.default_rng(3)
    with PhysicsWorld() as world:
        bowl = create_kitchenware(world.client, vessel_geometry(BOWL), material=BodyMaterial(0.0))
        cup_dims = VesselDims(0.07, 0.08, 0.1)
        cup = create_kitchenware(
            world.client,
            vessel_geometry(cup_dims, "cup"),
            (0.3, 0.0, 0.0),
            material=BodyMaterial(0.0),
        )
        in_bowl = spawn_beads_in(bowl, BeadSpec(count=80), rng)
        in_cup = spawn_beads_in(cup, BeadSpec(count=30), rng)
        bodies = p.getNumBodies(physicsClientId=world.client)
        world.step(world.steps_for(1.5))
        positions = bead_positions(world.client, np.concatenate([in_bowl, in_cup]))
        counts = count_contained({"bowl": bowl, "cup": cup}, positions)
        assert p.getNumBodies(physicsClientId=world.client) == bodies
        assert counts == {"bowl": 80, "cup": 30}
        assert count_lost(positions) == 0
        # Tilting the cup's frame makes the same bead positions count differently.
        cup.set_pose((0.3, 0.0, 0.0), p.getQuaternionFromEuler([np.pi, 0.0, 0.0]))
        assert contained_mask(cup, positions).sum() == 0
