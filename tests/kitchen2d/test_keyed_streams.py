"""Kitchen2D's learned streams draw per input tuple (KeyedRandom): the controls a pour
gives for its inputs do not depend on the scoops drawn before it, so a new model for one
skill leaves the other skills' samples as they were."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ltamp_cli.planner.problem import load_problem

ROOT = Path(__file__).resolve().parents[2]
COFFEE = ROOT / "problems/kitchen2d/coffee.yaml"


@pytest.fixture(scope="module")
def make(load_bindings: Any) -> Any:
    bindings = load_bindings("domains/kitchen2d/streams.py")
    world = load_problem(COFFEE).world
    return lambda seed: bindings.make_streams(world, np.random.default_rng(seed))


def _function(binding: Any) -> Any:
    return getattr(binding, "function", binding)


def test_pours_do_not_depend_on_the_scoops_drawn_before(make: Any, first_outputs: Any) -> None:
    alone, after_scoops = make(0), make(0)
    pose = next(iter(_function(alone["sample-placement"])("cup", "coaster")))[0]
    scoops = _function(after_scoops["sample-scoop"])("spoon", "sugar", "p_sugar")
    assert first_outputs(scoops, 3), "the scoop stream gave nothing: nothing was drawn"
    pour = ("cream", "cup", pose, "coaster")
    expected = first_outputs(_function(alone["sample-pour"])(*pour), 2)
    assert len(expected) == 2, "fewer than two pours: the test compares too little"
    assert first_outputs(_function(after_scoops["sample-pour"])(*pour), 2) == expected
    assert first_outputs(_function(make(1)["sample-pour"])(*pour), 2) != expected
