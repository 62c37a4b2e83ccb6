"""Kitchen2D's learned streams draw per input tuple (KeyedRandom): the controls a pour
gives for its inputs do not depend on the scoops drawn before it, so a new model for one
skill leaves the other skills' samples as they were."""

from __future__ import annotations

import importlib.util
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from ltamp_cli.planner.keyed_random import key_digest
from ltamp_cli.planner.problem import load_problem

ROOT = Path(__file__).resolve().parents[2]
COFFEE = ROOT / "problems/kitchen2d/coffee.yaml"


def _bindings() -> ModuleType:
    spec = importlib.util.spec_from_file_location(
        "kitchen2d_streams_keyed_under_test", ROOT / "domains/kitchen2d/streams.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def make() -> Any:
    bindings, world = _bindings(), load_problem(COFFEE).world
    return lambda seed: bindings.make_streams(world, np.random.default_rng(seed))


def _function(binding: Any) -> Any:
    return getattr(binding, "function", binding)


def _first_outputs(generator: Iterator[Any], n: int, calls: int = 40) -> list[int]:
    """Digests of the first ``n`` output tuples."""
    found: list[Any] = []
    for _ in range(calls):
        batch = next(generator, None)
        if batch is None:
            break
        found.extend(batch if isinstance(batch, list) else [batch])
        if len(found) >= n:
            break
    return [key_digest(outputs) for outputs in found[:n]]


def test_pours_do_not_depend_on_the_scoops_drawn_before(make: Any) -> None:
    alone, after_scoops = make(0), make(0)
    pose = next(iter(_function(alone["sample-placement"])("cup", "coaster")))[0]
    scoops = _function(after_scoops["sample-scoop"])("spoon", "sugar", "p_sugar")
    assert _first_outputs(scoops, 3), "the scoop stream gave nothing: nothing was drawn"
    pour = ("cream", "cup", pose, "coaster")
    expected = _first_outputs(_function(alone["sample-pour"])(*pour), 2)
    assert len(expected) == 2, "fewer than two pours: the test compares too little"
    assert _first_outputs(_function(after_scoops["sample-pour"])(*pour), 2) == expected
    assert _first_outputs(_function(make(1)["sample-pour"])(*pour), 2) != expected
