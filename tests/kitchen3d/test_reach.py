"""The kitchen3d ``test-reach`` stream (eager, in the domains of picks, pushes and pours):
push_to_reach's far bowl is out of arm r0's reach and its far cup out of arm r1's, each in
the other arm's; and the bound cuts no pick the arm could make (no grasp of the cup has an IK
solution just beyond it, for either arm), so it only spares futile IK and search."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from ltamp_cli.backends.pybullet.tamp.planning import PlanningWorld
from ltamp_cli.backends.pybullet.tamp.scene import scene_from_world
from ltamp_cli.planner.problem import load_problem

ROOT = Path(__file__).resolve().parents[2]
BOWL_AT, CUP_AT = (0.45, 0.3), (-0.45, -0.3)


def _bindings() -> ModuleType:
    spec = importlib.util.spec_from_file_location(
        "kitchen3d_streams_under_test", ROOT / "domains/kitchen3d/streams.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_far_objects_are_out_of_one_arms_reach_and_in_the_others() -> None:
    world = load_problem(ROOT / "problems/kitchen3d/push_to_reach.yaml").world
    reach = _bindings().make_streams(world, np.random.default_rng(0))["test-reach"].function
    assert not reach(0, "bowl", BOWL_AT) and reach(1, "bowl", BOWL_AT)
    assert reach(0, "cup", CUP_AT) and not reach(1, "cup", CUP_AT)
    assert reach(0, "bowl", (0.05, 0.1)) and reach(1, "bowl", (0.05, 0.1))  # the middle


@pytest.mark.slow
def test_no_pick_just_beyond_the_reach_bound() -> None:
    bound = _bindings().MAX_TOOL_REACH_M
    planning = PlanningWorld(scene_from_world(
        load_problem(ROOT / "problems/kitchen3d/push_to_reach.yaml").world))
    rng = np.random.default_rng(0)
    try:
        grasps = planning.grasp_values("cup")
        for arm in (0, 1):
            bx, by = planning.base_xy(arm)
            toward = -1.0 if bx > 0 else 1.0  # towards the table's middle
            near = (bx + toward * 0.75, by)
            beyond = bound + 0.01
            far = (bx + toward * math.cos(0.3) * beyond, by + math.sin(0.3) * beyond)
            # The IK does reach the cup well inside the bound (the test could fail)...
            assert any(list(planning.pick_kinematics("cup", near, g, rng, arms=(arm,)))
                       for g in grasps)
            # ...and finds no pick of any grasp just beyond it.
            assert not any(list(planning.pick_kinematics("cup", far, g, rng, arms=(arm,)))
                           for g in grasps)
    finally:
        planning.close()
