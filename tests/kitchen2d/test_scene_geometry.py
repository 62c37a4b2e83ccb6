"""Kitchen2D scenes and planning geometry: seeded arrangements, approaches, motions."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from ltamp_cli.backends.box2d.scene import default_grasp, scene_from_world
from ltamp_cli.backends.box2d.tamp import KitchenGeometry, empty_hand_path
from ltamp_cli.errors import InputError

WORLD = {
    "layout": {"table_x0": -38.0, "table_x1": 38.0, "coaster_x": -27.0, "faucet_x": 27.0},
    "objects": {
        "cup": {"kind": "cup", "width": [3.8, 4.4], "height": [3.0, 3.6]},
        "cream": {"kind": "cup", "width": 3.4, "height": 3.2, "material": "cream"},
        "sugar": {"kind": "bowl", "width": 6.0, "height": 4.2, "material": "sugar"},
        "spoon": {"kind": "spoon"},
        "stirrer": {"kind": "stirrer"},
    },
    "storage": [-18.0, 17.0],
}


def test_arrangement_is_seeded_and_objects_do_not_overlap() -> None:
    first = scene_from_world(WORLD, np.random.default_rng(3))
    again = scene_from_world(WORLD, np.random.default_rng(3))
    other = scene_from_world(WORLD, np.random.default_rng(4))
    assert first == again
    assert [o.home for o in first.objects] != [o.home for o in other.objects]
    for spec in (first, other):
        geometry = KitchenGeometry(spec)
        names = spec.names
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                pa = (spec.object(a).home, geometry.top)
                pb = (spec.object(b).home, geometry.top)
                assert geometry.cfree(a, pa, b, pb), (a, b)
        # Everything stays inside the storage range.
        for item in spec.objects:
            left, right, _ = item.extent()
            assert item.home + left >= -18.0 and item.home + right <= 17.0


def test_cfree_detects_two_cups_on_the_coaster() -> None:
    spec = scene_from_world(WORLD, np.random.default_rng(0))
    geometry = KitchenGeometry(spec)
    coaster = geometry.placements("cup", "coaster")[0]
    assert geometry.placements("cream", "coaster") == [coaster]
    assert not geometry.cfree("cup", coaster, "cream", coaster)
    assert geometry.placements("spoon", "coaster") == []


@pytest.mark.parametrize(
    ("world", "message"),
    [
        ({"objects": {"x": {"kind": "teapot"}}}, "kind"),
        ({"objects": {"x": {"kind": "cup", "width": "wide"}}}, "width"),
        ({"objects": {"x": {"kind": "cup"}}, "storage": [0.0, 3.0]}, "storage"),
        ({"objects": {"x": {"kind": "cup"}}, "layout": {"colour": 1}}, "layout"),
        ({"objects": {}}, "objects"),
    ],
)
def test_bad_world_is_an_input_error(world: dict, message: str) -> None:
    with pytest.raises(InputError, match=message):
        scene_from_world(world, np.random.default_rng(0))


def test_approaches_start_above_every_column_and_stay_clear() -> None:
    spec = scene_from_world(WORLD, np.random.default_rng(1))
    geometry = KitchenGeometry(spec)
    for name in ("cup", "cream", "stirrer"):
        item = spec.object(name)
        grasp = default_grasp(item)
        for region in ("table", "coaster", "faucet"):
            for pose in geometry.placements(name, region):
                found = geometry.kinematics(name, pose, grasp)
                assert found is not None, (name, region)
                conf, approach = found
                assert conf == approach[0]
                # Carried object clears every column at the conf.
                assert conf[1] - grasp[1] > geometry.ceiling
                grasp_point = (pose[0] + grasp[0], pose[1] + grasp[1])
                assert approach[-1] == pytest.approx(grasp_point, abs=1e-3)
                empty = empty_hand_path(approach)
                # The empty hand always ends with a vertical descent onto the bar.
                assert empty[-2][0] == pytest.approx(empty[-1][0])


def test_motion_avoids_a_wall_with_rrt_connect() -> None:
    world = dict(WORLD, walls=[[0.0, 1.0, 29.5]])  # a wall rising to y = 49.5
    spec = scene_from_world(world, np.random.default_rng(0))
    geometry = KitchenGeometry(spec)
    start, goal = (-30.0, 32.0), (30.0, 32.0)
    path = geometry.plan_motion(start, goal)
    # The hand cannot get over a wall this high (the world is 50 high): no path.
    assert path is None
    spec = scene_from_world(dict(WORLD, walls=[[0.0, 1.0, 20.0]]), np.random.default_rng(0))
    geometry = KitchenGeometry(spec)
    path = geometry.plan_motion(start, goal)
    assert path is not None and path[0] == start and path[-1] == goal
    assert max(y for _, y in path) > 40.0  # it had to go over the wall
    obstacles = geometry.obstacles()
    for (x0, y0), (x1, y1) in itertools.pairwise(path):
        for f in np.linspace(0.0, 1.0, 50):
            rects = geometry.hand_rects(None, None, x0 + f * (x1 - x0), y0 + f * (y1 - y0))
            assert not geometry.overlaps(rects, obstacles)


def test_direct_transit_goes_above_the_columns() -> None:
    spec = scene_from_world(WORLD, np.random.default_rng(2))
    geometry = KitchenGeometry(spec)
    grasp = default_grasp(spec.object("cup"))
    home = geometry.placements("cup", "table")[0]
    coaster = geometry.placements("cup", "coaster")[0]
    q1, _ = geometry.kinematics("cup", home, grasp)
    q2, _ = geometry.kinematics("cup", coaster, grasp)
    path = geometry.plan_motion(q1, q2, "cup", grasp)
    assert path is not None and path[0] == q1 and path[-1] == q2
    assert geometry.segment_free(spec.object("cup"), grasp, path)
    # Carrying the cup straight through the neighbouring columns is not allowed.
    assert not geometry.segment_free(spec.object("cup"), grasp,
                                     [(q1[0], home[1] + grasp[1]), (q2[0], home[1] + grasp[1])])
