"""The Panda in the loop of a Kitchen3D trial (``robot="panda"``): the grasped cup follows the
path, an unreachable pose fails with "reach", an arm driven into the table fails with
"collision", a weak grasp slips where a strong one holds; the robot is part of the records'
identity."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.kitchenware_geometry import VesselDims, vessel_geometry
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial, KitchenwareBody
from ltamp_cli.backends.pybullet.paths import PosePath, rotation_about_axis, timed_poses
from ltamp_cli.backends.pybullet.robot.pose import Pose, rotation_distance
from ltamp_cli.backends.pybullet.skills.robot import (
    RobotFailure,
    RobotSettings,
    RobotTrialPhysics,
    timed_configurations,
)
from ltamp_cli.backends.pybullet.world import PhysicsWorld
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.trials.collect import CollectJob, pending_indices
from ltamp_cli.trials.record import TrialDataset, TrialRecord

#: A cup the Panda's 8 cm gripper can hold (7 cm at the top), 0.2 kg.
CUP = vessel_geometry(VesselDims(base_diameter=0.06, top_diameter=0.07, height=0.10), "cup")
MATERIAL = BodyMaterial(mass=0.2, lateral_friction=0.5, restitution=0.1)


@pytest.fixture()
def world() -> Iterator[PhysicsWorld]:
    with PhysicsWorld() as physics_world:
        yield physics_world


def tilt_path(start: np.ndarray, shift: np.ndarray, pitch: float) -> PosePath:
    """Cup base poses: from upright at ``start`` ``(3,)`` to ``start + shift``, tilted by
    ``pitch`` about ``y`` (the pour's rotation), in 5 waypoints."""
    fractions = np.linspace(0.0, 1.0, 5)
    positions = np.array([start + f * shift for f in fractions])
    quaternions = np.array([rotation_about_axis("y", f * pitch) for f in fractions])
    return PosePath(positions, quaternions)


def carry(world: PhysicsWorld, path: PosePath, settings: RobotSettings | None = None
          ) -> KitchenwareBody:
    """Grasp the cup at the path's start, hold it 0.2 s, follow the path, hold 0.2 s."""
    physics = RobotTrialPhysics(world, path, settings or RobotSettings(), seed=0)
    physics.reset()
    cup = physics.add_body(CUP, MATERIAL, "tool", path.positions[0], path.quaternions[0])
    physics.hold(cup, path.positions[0], path.quaternions[0], physics.steps_for(0.2))
    timed = timed_poses(path, speed=0.2, angular_speed=2.0, dt=physics.time_step)
    physics.follow(cup, timed)
    physics.hold(cup, path.positions[-1], path.quaternions[-1], physics.steps_for(0.2))
    return cup


#: A reachable pour-like motion: 10 cm along -x while tilting to 90°.
REACHABLE = tilt_path(np.array([0.1, 0.0, 0.15]), np.array([-0.1, 0.0, 0.05]), -math.pi / 2)


def test_a_grasped_cup_ends_where_its_path_ends(world: PhysicsWorld) -> None:
    cup = carry(world, REACHABLE)
    position, quaternion = cup.pose()
    end = Pose(REACHABLE.positions[-1], REACHABLE.quaternions[-1])
    start = Pose(REACHABLE.positions[0], REACHABLE.quaternions[0])
    # The path is long enough that a cup left at its start could not pass.
    assert np.linalg.norm(end.position - start.position) > 0.1
    assert np.linalg.norm(position - end.position) < 0.01
    assert rotation_distance(Pose(position, quaternion), end) < 0.05


def test_an_unreachable_pose_fails_with_reach(world: PhysicsWorld) -> None:
    far = tilt_path(np.array([0.0, 0.0, 0.15]), np.array([-1.5, 0.0, 0.0]), 0.0)
    with pytest.raises(RobotFailure) as failure:
        carry(world, far)
    assert failure.value.reason == "reach"
    assert failure.value.result(-1.0).score == -1.0


@pytest.mark.parametrize("planned", [True, False])
def test_a_path_into_the_table_fails_with_collision(world: PhysicsWorld, planned: bool) -> None:
    # The hand 1.5 cm above the cup's base; without the planner's collision checks the
    # contact met while simulating fails the trial.
    low = RobotSettings(grasp_heights=(0.15,), rim_grasps=False, plan_collisions=planned)
    down = tilt_path(np.array([0.0, 0.0, 0.2]), np.array([0.0, 0.0, -0.2]), 0.0)
    with pytest.raises(RobotFailure) as failure:
        carry(world, down, low)
    assert failure.value.reason == "collision"
    assert ("step" in failure.value.detail) != planned  # found while simulating, or before
    # The same grasp going only halfway down is carried out.
    halfway = tilt_path(np.array([0.0, 0.0, 0.2]), np.array([0.0, 0.0, -0.1]), 0.0)
    cup = carry(world, halfway, low)
    assert np.linalg.norm(cup.pose()[0] - halfway.positions[-1]) < 0.01


def test_a_weak_grasp_slips_where_a_strong_one_holds(world: PhysicsWorld) -> None:
    carry(world, REACHABLE, RobotSettings(grasp_force=200.0))  # no failure
    with pytest.raises(RobotFailure) as failure:
        # 0.5 N cannot hold a 0.2 kg cup (weight ~2 N) against gravity.
        carry(world, REACHABLE, RobotSettings(grasp_force=0.5))
    assert failure.value.reason == "slip"


def test_timed_configurations_respect_the_joint_speed_and_end_exactly() -> None:
    path = np.array([[0.0] * 7, [0.5] + [0.1] * 6, [1.0] + [0.0] * 6])
    dt = 1.0 / 240.0
    targets = timed_configurations(path, speed=2.0, acceleration=8.0, dt=dt)
    np.testing.assert_allclose(targets[-1], path[-1])
    speeds = np.abs(np.diff(np.vstack([path[:1], targets]), axis=0)) / dt
    assert speeds.max() <= 2.0 + 1e-9
    # Rest to rest over 1 rad at 2 rad/s and 8 rad/s²: 0.5 s cruise + 0.25 s of ramps.
    assert len(targets) * dt == pytest.approx(0.75, abs=2 * dt)


def test_the_robot_is_part_of_the_backend_identity() -> None:
    free, robot = load_backend("pybullet"), load_backend("pybullet", robot="panda")
    side_only = load_backend("pybullet", robot="panda",
                             robot_settings=RobotSettings(rim_grasps=False))
    try:
        assert free.name == "pybullet" and robot.name == "pybullet+panda"
        # A 10 cm cup is wider than the gripper at every height: with side grasps only, a
        # failed (valid) trial; the rim grasp holds it and the pour is carried out.
        context = np.array([0.2, 0.08, 0.12, 0.10, 0.10, 0.10])
        control = np.array([-3 * math.pi / 4, -0.5, 0.5, 0.15, 0.12])
        assert robot.is_valid("pour", context, control[None])[0]
        result = side_only.run_trial("pour", context, control, 0)
        assert (result.score, result.valid, result.info["reason"]) == (-1.0, True, "grasp")
        result = robot.run_trial("pour", context, control, 0)
        assert result.valid and "reason" not in result.info, result.info
        assert result.info["beads_in_cup_start"] > 0
    finally:
        free.close()
        robot.close()
        side_only.close()
    with pytest.raises(InputError, match="robot"):  # bad input: one line, exit 2
        load_backend("pybullet", robot="kuka")


def test_free_and_robot_records_never_share_a_file(tmp_path: Path) -> None:
    job = CollectJob(skill="pour", backend="pybullet", n=2, robot="panda")
    assert job.tag == "pybullet+panda" and job.options() == {"robot": "panda"}
    dataset = TrialDataset(tmp_path / "trials.jsonl")
    dataset.append(TrialRecord(skill="pour", context=(0.0,) * 6, control=(0.0,) * 5,
                               score=-1.0, valid=True, seed=0, backend="pybullet", index=5))
    with pytest.raises(InputError, match="pybullet/pour trials, not pybullet\\+panda"):
        pending_indices(dataset, job)


def run_cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str]:
    with pytest.raises(SystemExit) as done:
        main(list(args))
    return int(done.value.code or 0), capsys.readouterr().err


def test_collect_robot_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = str(tmp_path / "pour.jsonl")
    for bad in (["--backend", "box2d", "--robot", "panda"], ["--robot", "kuka"],
                ["--backend", "sapien", "--robot", "panda"]):
        args = ["collect", "pour", "-n", "1", "--out", out, *bad]
        code, err = run_cli(capsys, *args)
        assert code == 2 and len(err.strip().splitlines()) == 1 and "--robot" in err, err
    code, err = run_cli(capsys, "collect", "pour", "-n", "1", "--out", out, "--backend",
                        "pybullet", "--robot", "panda")
    assert code == 0, err
    (record,) = TrialDataset(out).read()
    assert record.backend == "pybullet+panda"
    # The same file cannot be continued with free-floating trials.
    code, err = run_cli(capsys, "collect", "pour", "-n", "2", "--out", out, "--backend",
                        "pybullet")
    assert code == 2 and "pybullet+panda/pour trials, not pybullet/pour" in err, err


def test_train_robot_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, err = run_cli(capsys, "train", "pour", "--backend", "box2d", "--robot", "panda",
                        "--out", str(tmp_path / "m1"))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--robot" in err, err
    # A model directory with free-floating trials is not resumed with the robot.
    TrialDataset(tmp_path / "m2" / "trials.jsonl").append(TrialRecord(
        skill="pour", context=(0.2, 0.08, 0.12, 0.07, 0.1, 0.06),
        control=(-2.0, 0.0, 0.0, 0.1, 0.05), score=-1.0, valid=True, seed=1,
        backend="pybullet", index=0))
    code, err = run_cli(capsys, "train", "pour", "--backend", "pybullet", "--robot", "panda",
                        "--budget", "2", "--init", "2", "--out", str(tmp_path / "m2"))
    assert code == 2 and "holds pybullet trials, not pybullet+panda" in err, err
