"""Kitchen3D streams draw per instance (KeyedRandom): what one stream gives for its inputs
does not depend on the draws other streams made before it, so a new model for one skill
(or another planner order) leaves the other streams' samples as they were."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ltamp_cli.planner.keyed_random import key_digest
from ltamp_cli.planner.problem import load_problem

ROOT = Path(__file__).resolve().parents[2]
COFFEE = ROOT / "problems/kitchen3d/coffee.yaml"


@pytest.fixture(scope="module")
def make(load_bindings: Any) -> Any:
    bindings = load_bindings("domains/kitchen3d/streams.py")
    world = load_problem(COFFEE).world
    return lambda seed: bindings.make_streams(world, np.random.default_rng(seed))


def _grasp(streams: dict[str, Any], name: str) -> Any:
    return next(streams["sample-grasp"].function(name))[0]


def test_pours_do_not_depend_on_the_scoops_drawn_before(make: Any, first_outputs: Any) -> None:
    alone, after_scoops = make(0), make(0)
    cup_grasp = _grasp(alone, "cup")
    pour_inputs = (0, "cup", cup_grasp, "bowl", (0.0, -0.12))
    scoops = after_scoops["sample-scoop"].function(1, "spoon", _grasp(after_scoops, "spoon"),
                                                   "sugarbowl", (0.22, 0.2))
    assert first_outputs(scoops, 2), "the scoop stream gave nothing: nothing was drawn"
    first_outputs(after_scoops["inverse-kinematics"].function(  # and an IK meanwhile
        0, "cup", (-0.2, 0.12), cup_grasp), 1)
    expected = first_outputs(alone["sample-pour"].function(*pour_inputs), 1)
    assert expected, "no pour found: the test compares nothing"
    assert first_outputs(after_scoops["sample-pour"].function(*pour_inputs), 1) == expected
    # and a different seed draws other pours (the keys are not all there is)
    assert first_outputs(make(1)["sample-pour"].function(*pour_inputs), 1) != expected


def test_ik_and_motions_do_not_depend_on_earlier_calls(make: Any, first_outputs: Any) -> None:
    alone, busy = make(0), make(0)
    for other in ("spoon", "stirrer"):  # other IK calls first, on the busy copy only
        first_outputs(busy["inverse-kinematics"].function(1, other, (0.25, -0.3),
                                                           _grasp(busy, other)), 1)
    for (grasp,) in alone["sample-grasp"].function("cup"):
        ik = (0, "cup", (-0.2, 0.12), grasp)
        found = list(next(alone["inverse-kinematics"].function(*ik), []))
        if found:
            break
    else:
        pytest.fail("no grasp of the cup has an IK solution: the test compares nothing")
    again = list(next(busy["inverse-kinematics"].function(*ik), []))
    assert [key_digest(x) for x in again] == [key_digest(x) for x in found]
    home = load_problem(COFFEE).objects["q0"][1]
    motion = (0, home, found[0][0])
    first_outputs(busy["plan-free-motion"].function(0, found[0][0], home), 2)  # back first
    path = first_outputs(alone["plan-free-motion"].function(*motion), 2)
    assert len(path) == 2 and path == first_outputs(
        busy["plan-free-motion"].function(*motion), 2)
