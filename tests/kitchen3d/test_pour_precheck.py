"""Kitchen3D GoodPour physics pre-check: a 30-bead PyBullet trial keeps controls that pour
with a margin and drops marginal ones; its per-call budget; bad settings are input errors."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from ltamp_cli.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
POUR_BLOCKED = ROOT / "problems" / "kitchen3d" / "pour_blocked.yaml"
# pour_blocked's context (bowl d/h/base, cup d/h/base, metres) and two of the controls the
# learned stream drew for it: one tilts the cup far and pours everything (100 % with ~100
# beads on PyBullet and SAPIEN), one tilts it just past horizontal (73 % PyBullet, 72 %
# SAPIEN: a failed pour that the model ranked as confident).
CONTEXT = np.array([0.2, 0.07, 0.12, 0.07, 0.11, 0.06])
FULL = np.array([-2.38, 0.716, -0.056, 0.236, 0.105])
MARGINAL = np.array([-1.628, -0.353, -0.425, 0.711, 0.083])


def _streams_module() -> ModuleType:
    spec = importlib.util.spec_from_file_location(
        "kitchen3d_streams_under_test", ROOT / "domains" / "kitchen3d" / "streams.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_precheck_keeps_a_full_pour_drops_a_marginal_one_within_its_budget() -> None:
    streams = _streams_module()
    check = streams.PhysicsCheck("pour", limit=2, min_score=0.5)
    check.begin()
    assert check(CONTEXT, FULL)
    assert not check(CONTEXT, MARGINAL)
    assert (check.checked, check.rejected) == (2, 1)
    assert check.spent
    # Known verdicts cost no trial, even with the budget spent; new controls are refused.
    assert check(CONTEXT, FULL) and not check(CONTEXT, MARGINAL)
    assert not check(CONTEXT, FULL + np.array([-0.2, 0.0, 0.0, 0.0, 0.0]))
    assert check.checked == 2
    # The passed control is offered again for the same context only.
    np.testing.assert_allclose(check.passed(CONTEXT), [FULL])
    assert check.passed(CONTEXT + 0.01) == []
    # A new stream call gets a new budget.
    check.begin()
    assert not check.spent


@pytest.mark.parametrize(("key", "value", "needle"), [
    ("precheck", ["scoop"], "world.precheck"),
    ("precheck", "pour", "world.precheck"),
    ("precheck_limit", 0, "world.precheck_limit"),
    ("precheck_min_score", 2.0, "world.precheck_min_score"),
])
def test_bad_precheck_settings_are_input_errors(key: str, value: object, needle: str) -> None:
    from ltamp_cli.planner.problem import load_problem

    problem = load_problem(POUR_BLOCKED)
    world = {**dict(problem.world), key: value}
    with pytest.raises(InputError, match=needle):
        problem.streams_factory(world, np.random.default_rng(0))
