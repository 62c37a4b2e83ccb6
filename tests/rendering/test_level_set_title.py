"""Level-set plots say what they show: skill, context with units, held controls."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.backends.box2d.skills import push
from ltamp_cli.backends.protocol import ParamSpace
from ltamp_cli.cli.plot import _spec_with_units
from ltamp_cli.learning.model_dir import load_model, spec_from_json, spec_to_json
from ltamp_cli.sampling.level_set_plot import default_title
from ltamp_cli.sampling.superlevel import build_superlevel_set

ROOT = Path(__file__).resolve().parents[2]


def shipped_push_model() -> Path:
    """The shipped Kitchen2D push model, wherever the repository keeps its models."""
    found = sorted(ROOT.glob("**/models/kitchen2d/push/model.json"))
    assert found, "the shipped kitchen2d push model is missing"
    return found[0].parent


def test_units_round_trip_and_label_axes() -> None:
    spec = push.SPEC
    # a saved spec keeps no outcome (its score function is code, not data)
    assert spec_from_json(spec_to_json(spec)) == dataclasses.replace(spec, outcome=None)
    assert spec.control.label(2) == "angle [rad]" and spec.control.label(3) == "duration [s]"
    bare = ParamSpace(("a",), (0.0,), (1.0,))
    other = ParamSpace(("b",), (0.0,), (1.0,))  # a skill's names are distinct (SkillSpec)
    assert bare.label(0) == "a" and spec_from_json(spec_to_json(
        push.SPEC.__class__("s", bare, other))).control.units == ()
    with pytest.raises(ValueError, match="units"):
        ParamSpace(("a", "b"), (0.0, 0.0), (1.0, 1.0), ("m",))


def test_the_title_names_the_context_with_units_and_the_held_controls() -> None:
    loaded = load_model(shipped_push_model())
    model = loaded.model
    assert model.spec.control.units == ("units", "units", "rad", "s")  # saved with units
    # A model saved before specs had units gets them from its backend.
    bare = dataclasses.replace(model.spec, **{
        part: ParamSpace(space.names, space.lows, space.highs)
        for part, space in (("context", model.spec.context), ("control", model.spec.control))})
    assert not bare.control.units and not bare.context.units
    spec = _spec_with_units(bare, loaded.metadata.get("backend"))
    assert spec.control.units == ("units", "units", "rad", "s")
    superlevel = build_superlevel_set(model, np.array([2.0, -1.0]), np.random.default_rng(0))
    title = default_title(superlevel, (0, 1), spec)
    flat = " ".join(title.splitlines())
    assert flat.startswith("push: predicted level set")
    assert "goal_x = 2 units, goal_y = -1 units" in flat
    assert "angle = " in flat and " rad" in flat and "duration = " in flat and " s" in flat
    assert "rx" not in flat.split("held at")[1]  # the drawn controls are not "held"
    assert max(len(line) for line in title.splitlines()) <= 72


@pytest.mark.parametrize("backend_name", ["box2d", "pybullet"])
def test_every_physical_skill_parameter_has_a_unit(backend_name: str) -> None:
    # Plots label axes and titles with these; a skill added without them would plot bare names.
    from ltamp_cli.backends import load_backend

    backend = load_backend(backend_name)
    try:
        for name, spec in backend.skills().items():
            for space in (spec.context, spec.control):
                assert len(space.units) == len(space.names), (backend_name, name, space.names)
    finally:
        backend.close()
