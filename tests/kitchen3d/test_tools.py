"""Kitchen3D tool skills in the planner's geometry: stir and dump tool paths, the push stream
(the arm that reaches the bowl pushes it, the other cannot), the faucet of ``unclog`` blocking
scoop approaches, and the table-size option."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from ltamp_cli.backends.kitchenware_geometry import SpoonDims
from ltamp_cli.backends.pybullet.robot.pose import Pose
from ltamp_cli.backends.pybullet.tamp import skill_paths
from ltamp_cli.backends.pybullet.tamp.planning import PlanningWorld
from ltamp_cli.backends.pybullet.tamp.scene import scene_from_world
from ltamp_cli.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
PROBLEMS = ROOT / "problems" / "kitchen3d"
TABLE_Z = 0.7
BOWL = {"kind": "bowl", "top_diameter": 0.18, "base_diameter": 0.11, "height": 0.07,
        "fixed": True, "at": [0.05, -0.15]}


def _world(path: Path) -> dict:
    return yaml.safe_load(path.read_text())["world"]


def test_stir_path_circles_inside_the_bowl_below_its_rim() -> None:
    scene = scene_from_world({"objects": {"bowl": BOWL, "stirrer": {"kind": "stirrer"}}})
    bowl = scene.object("bowl")
    dims = bowl.vessel()
    poses = skill_paths.stir_tool_poses(scene.object("stirrer"), bowl, (0.05, -0.15), TABLE_Z,
                                        0.3)
    tips = np.array([pose.position for pose in poses]) - np.array([0.05, -0.15, TABLE_Z])
    # Enters from above the rim, then every waypoint keeps the tip inside, off the floor.
    assert tips[0, 2] > dims.height
    inside = tips[1:]
    radius = np.hypot(inside[:, 0], inside[:, 1])
    assert np.all(inside[:, 2] > dims.thickness)
    assert np.all(inside[:, 2] < dims.height)
    assert np.all(radius < dims.outer_radius_at(inside[:, 2]) - dims.thickness - 0.004)
    # It actually stirs: the tip goes round (covers every quadrant) at a real radius.
    angles = np.mod(np.arctan2(inside[:, 1], inside[:, 0])[radius > 0.01], 2 * math.pi)
    assert set(np.floor(angles / (math.pi / 2)).astype(int)) == {0, 1, 2, 3}
    # The rod stays upright.
    for pose in poses:
        assert pose.rotation()[2, 2] == pytest.approx(1.0)


def test_dump_rolls_the_spoon_past_the_side_above_the_bowl() -> None:
    scene = scene_from_world({"objects": {"bowl": BOWL, "spoon": {"kind": "spoon",
                                                                  "length": 0.2}}})
    bowl, spoon = scene.object("bowl"), scene.object("spoon")
    head = SpoonDims(0.2).head()
    for sign in (1.0, -1.0):
        poses = skill_paths.dump_tool_poses(spoon, bowl, (0.05, -0.15), TABLE_Z, 0.7, sign)
        # Upright at first (level carry), past horizontal at the end: the opening faces down.
        assert poses[0].rotation()[2, 2] == pytest.approx(1.0)
        assert poses[-1].rotation()[2, 2] < -0.1
        for pose in poses:  # the head's centre stays over the bowl, above its rim
            centre = (pose @ Pose(np.array([0.0, 0.0, head.height / 2]))).position
            assert math.hypot(centre[0] - 0.05, centre[1] + 0.15) < 1e-6
            assert centre[2] > TABLE_Z + bowl.vessel().height + 0.04


@pytest.fixture(scope="module")
def push_world():  # type: ignore[no-untyped-def]
    planning = PlanningWorld(scene_from_world(_world(PROBLEMS / "push_to_reach.yaml")))
    yield planning
    planning.close()


def test_push_path_moves_the_hand_along_the_line_at_push_height(push_world) -> None:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(0)
    spec = push_world.spec.object("bowl")
    start, goal = (0.45, 0.3), (-0.05, 0.0)
    direction = np.subtract(goal, start) / np.linalg.norm(np.subtract(goal, start))
    heading = math.atan2(direction[1], direction[0])
    reached = {}
    poses = skill_paths.push_hand_poses(spec, start, goal, TABLE_Z, heading)
    for arm in (0, 1):
        # The Cartesian follower's IK restarts are random (about half of them find this
        # path for arm 1); the planner calls the stream again, so a few tries here.
        for _ in range(5):
            reached[arm] = push_world.follow_hand_path(poses, arm, rng, "push",
                                                       touching="bowl")
            if reached[arm] is not None:
                break
    # Arm 0 stands 1.2 m away from the bowl: it cannot push it; arm 1 can.
    assert reached[0] is None
    path = reached[1]
    assert path is not None and path.touching == "bowl"
    arm = push_world.scene.arms[1]
    hand = []
    for q in path.configurations:
        arm.set_configuration(q)
        hand.append(arm.end_effector_pose().position)
    hand = np.array(hand)
    # Pushing 2 cm below the 7 cm rim (the palm passes above it).
    height = skill_paths.push_hand_height(spec)
    assert height == pytest.approx(0.07 - 0.02 + skill_paths.FINGERTIP_BELOW_M)
    low = hand[:, 2] < TABLE_Z + height + 0.005
    assert low.sum() >= 10
    # While low, the hand stays on the push line, and ends just behind the goal.
    rel = hand[low, :2] - np.asarray(start)
    across = np.abs(rel[:, 0] * direction[1] - rel[:, 1] * direction[0])
    assert across.max() < 0.01
    along = rel @ direction
    # The fingers lie across the line (hand yaw = heading): open, touching the round bowl
    # either side of it, closer behind its centre than its radius.
    behind = skill_paths.push_contact_distance(spec, skill_paths.push_finger_gap(spec, True))
    assert behind < spec.footprint()[0] + skill_paths.FINGER_HALF_M - 0.005
    goal_along = float(np.linalg.norm(np.subtract(goal, start)))
    assert along.max() == pytest.approx(goal_along - behind, abs=0.01)
    assert along.min() < -behind  # it starts behind the bowl, not inside it


def test_the_faucet_blocks_some_scoop_approaches() -> None:
    """unclog: the same scoop control with both spoon grasps at 8 yaws round the sink, with
    and without the faucet."""
    world = _world(PROBLEMS / "unclog.yaml")
    without = copy.deepcopy(world)
    del without["objects"]["faucet"]
    control = np.array([0.2, -0.35, 0.2, 0.01, 0.03])
    feasible = {}
    for label, w in (("faucet", world), ("none", without)):
        planning = PlanningWorld(scene_from_world(w))
        try:
            sink, spoon = planning.spec.object("sink"), planning.spec.object("spoon")
            heading = planning.base_yaw(0, sink.at)  # type: ignore[arg-type]
            feasible[label] = set()
            for grasp in planning.grasp_values("spoon"):
                for k in range(8):
                    poses = skill_paths.scoop_tool_poses(sink, spoon, sink.at,  # type: ignore[arg-type]
                                                         planning.table_z, control,
                                                         heading + k * math.pi / 4)
                    path = planning.follow_object_path("spoon", grasp, poses, 0,
                                                       np.random.default_rng(k), "scoop",
                                                       target="sink")
                    if path is not None:
                        feasible[label].add((grasp, k))
        finally:
            planning.close()
    assert feasible["none"], "no scoop approach at all: the test scene is broken"
    assert feasible["faucet"] < feasible["none"]  # strictly fewer: some are blocked


@pytest.mark.parametrize(("table", "message"), [
    ({"length": 5.0}, "world.table.length"),
    ({"width": "wide"}, "world.table.width"),
    ({"height": 1.0}, "world.table"),
    ([1.4, 0.9], "world.table"),
])
def test_bad_table_names_the_field(table, message) -> None:  # type: ignore[no-untyped-def]
    world = {"objects": {"bowl": BOWL}, "table": table}
    with pytest.raises(InputError, match=message):
        scene_from_world(world)


def test_table_length_moves_the_arms() -> None:
    planning = PlanningWorld(scene_from_world({"objects": {"bowl": BOWL}, "arms": 2,
                                               "table": {"length": 1.4}}))
    try:
        assert planning.base_xy(0)[0] == pytest.approx(-0.78)
        assert planning.base_xy(1)[0] == pytest.approx(0.78)
    finally:
        planning.close()
