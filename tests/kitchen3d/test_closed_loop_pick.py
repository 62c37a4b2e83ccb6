"""Closed-loop picks in the PyBullet executor: a pick looks where its object actually stands
and re-solves the approach relative to it, as a robot that re-perceives before grasping."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.backends.pybullet.executor import ActionFailed, ExecutionSettings, Kitchen3DRun
from ltamp_cli.backends.pybullet.robot.arm import PANDA_HOME
from ltamp_cli.backends.pybullet.tamp.planning import PlanningWorld
from ltamp_cli.backends.pybullet.tamp.scene import scene_from_world
from ltamp_cli.backends.pybullet.tamp.values import ArmConf
from ltamp_cli.planner.problem import load_problem

ROOT = Path(__file__).resolve().parents[2]
BLOCK_XY = (-0.068, 0.15)
HAS_SAPIEN = importlib.util.find_spec("sapien") is not None


def _run_class(backend: str) -> type[Kitchen3DRun]:
    if backend == "sapien":
        from ltamp_cli.backends.sapien.executor import SapienKitchen3DRun

        return SapienKitchen3DRun
    return Kitchen3DRun


def _pick_block(offset: tuple[float, float], perceive: bool, backend: str) -> Kitchen3DRun:
    """Plan a pick of pour_blocked's block where the problem has it; execute it with the
    block standing ``offset`` (m) from there. Returns the run (closed by the caller)."""
    spec = scene_from_world(load_problem(ROOT / "problems/kitchen3d/pour_blocked.yaml").world)
    planning = PlanningWorld(spec)
    try:
        rng = np.random.default_rng(0)
        grasp = planning.grasp_values("block")[0]
        conf, approach = next(planning.pick_kinematics("block", BLOCK_XY, grasp, rng))
        reach = planning.plan_motion(ArmConf.of(0, np.asarray(PANDA_HOME)), conf, None, seed=0)
        assert reach is not None
    finally:
        planning.close()
    actual = (BLOCK_XY[0] + offset[0], BLOCK_XY[1] + offset[1])
    run = _run_class(backend)(spec, {"cup": (0.0, 0.15), "block": actual}, 0,
                              ExecutionSettings(), None)
    if not perceive:  # the open-loop pick, for contrast
        run.perceived_approach = lambda name, grasp, path: path.configurations  # type: ignore[method-assign]
    try:
        run.run_step("move-free", [None, reach, None, 0], ["q0", "t0", "q1", "r0"])
        run.run_step("pick", ["block", BLOCK_XY, grasp, conf, approach, 0],
                     ["block", "p0", "g0", "q1", "a0", "r0"])
    except BaseException:
        run.close()
        raise
    return run


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["pybullet", pytest.param("sapien", marks=pytest.mark.skipif(
    not HAS_SAPIEN, reason="sapien is not installed"))])
def test_a_pick_reaches_an_object_that_stands_off_its_planned_pose(backend: str) -> None:
    # 2.5 cm along the fingers' closing direction (away from the cup): the open-loop pick
    # closes one finger inside it and the other beside it.
    with pytest.raises(ActionFailed, match="fingers"):
        _pick_block((-0.025, 0.0), perceive=False, backend=backend).close()
    run = _pick_block((-0.025, 0.0), perceive=True, backend=backend)
    try:
        perceived = [e for e in run.log if e["action"] == "perceive"]
        assert len(perceived) == 1 and perceived[0]["offset_m"] == pytest.approx(0.025, abs=3e-3)
        assert run.held[0][0] == "block"
        # Lifted in the hand: the block rides above the table with the arm.
        position, _ = run.bodies["block"].pose()
        assert position[2] > run.table_z + 0.02
        gaps = next(e for e in run.log if e["action"] == "pick")["finger_gaps_m"]
        assert max(gaps) <= 0.01
    finally:
        run.close()
