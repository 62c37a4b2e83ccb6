"""bench/context.py (context dependence of pour and scoop) and bench/kitchen3d_models.py
(θ* vs random valid controls through ``ltamp evaluate``'s own function)."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from bench import context, kitchen3d_models

ROOT = Path(__file__).resolve().parents[2]


def test_grid_is_the_2d_scoop_grid_in_its_order() -> None:
    grid = context.grid_contexts(np.array([5.0, 4.0]), np.array([10.0, 8.0]), [5, 3])
    expected = [[w, h] for w in (5.0, 6.25, 7.5, 8.75, 10.0) for h in (4.0, 6.0, 8.0)]
    np.testing.assert_allclose(grid, expected)


def test_trial_seeds_per_context_or_common() -> None:
    # one trial per context: seed * 100000 + context index (the 2D pour's committed cache)
    assert [context.trial_seed(3, i, 0, 1, False) for i in range(3)] == [
        300_000, 300_001, 300_002]
    # common random numbers: the same seeds in every context
    assert context.trial_seed(0, 7, 2, 8, True) == context.trial_seed(0, 1, 2, 8, True) == 2
    seeds = {context.trial_seed(0, i, j, 4, False) for i in range(5) for j in range(4)}
    assert len(seeds) == 20


def test_read_trials_keeps_valid_unique_trials_of_the_setting(tmp_path: Path) -> None:
    rows = [
        {"skill": "scoop", "backend": "pybullet", "valid": True, "score": 0.2,
         "context": [1.0], "control": [2.0]},
        {"skill": "scoop", "backend": "pybullet", "valid": True, "score": 0.2,
         "context": [1.0], "control": [2.0]},  # repeated input: used once
        {"skill": "scoop", "setting": "pybullet", "valid": True, "score": -0.5,
         "context": [1.5], "control": [2.5]},
        {"skill": "scoop", "setting": "sapien", "valid": True, "score": 0.9,
         "context": [3.0], "control": [3.0]},
        {"skill": "scoop", "backend": "pybullet", "valid": False, "score": -1.0,
         "context": [4.0], "control": [4.0]},
        {"skill": "pour", "backend": "pybullet", "valid": True, "score": 0.1,
         "context": [5.0], "control": [5.0]},
    ]
    path = tmp_path / "t.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    contexts, controls, scores = context.read_trials([path], "scoop", "pybullet")
    np.testing.assert_allclose(contexts, [[1.0], [1.5]])
    np.testing.assert_allclose(controls, [[2.0], [2.5]])
    np.testing.assert_allclose(scores, [0.2, -0.5])


def test_committed_2d_pour_result_is_reproduced_from_its_cache(tmp_path: Path) -> None:
    """The 80 cached trials give the committed rates and splits without a new trial."""
    committed = json.loads((ROOT / "docs/results/fidelity/pour_context.json").read_text())
    cache = tmp_path / "cache.jsonl"
    shutil.copy(ROOT / "docs/results/fidelity/pour_context_trials.jsonl", cache)
    before = cache.read_text()
    out = tmp_path / "out.json"
    assert context.main(["--skill", "pour", "--backend", "box2d", "--contexts", "80",
                         "--model", str(ROOT / "models/kitchen2d/pour"), "--cache", str(cache),
                         "--out", str(out), "--quiet"]) == 0
    assert cache.read_text() == before  # every trial came from the cache
    report = json.loads(out.read_text())
    # To float precision: the committed intervals came from scipy's Wilson interval, today's
    # from the closed form (last-digit differences).
    assert _close(report["fixed_control"]["overall"], committed["fixed_control"]["overall"])
    assert _close(report["fixed_control"]["splits"], committed["fixed_control"]["splits"])
    assert report["gp"]["lengthscales"] == committed["gp"]["lengthscales"]


def test_bad_grid_is_one_error_and_exit_2(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    code = context.main(["--skill", "scoop", "--backend", "box2d", "--grid", "3",
                         "--out", str(tmp_path / "o.json")])
    assert code == 2
    assert "--grid needs 2 counts" in capsys.readouterr().err
    assert not (tmp_path / "o.json").exists()


def test_kitchen3d_models_reports_evaluates_rates(tmp_path: Path) -> None:
    """The bench's rates are ``_live_success_rates``' on the same backend, and it records
    every live trial that function ran (θ* and the random baseline, per context)."""
    from ltamp_cli.backends import load_backend
    from ltamp_cli.cli.evaluate import _live_success_rates
    from ltamp_cli.learning.model_dir import load_model

    directory = ROOT / "models/kitchen2d/pour"
    summary = kitchen3d_models.bench_model(directory, 2, 0)
    backend = load_backend("box2d")
    try:
        expected = _live_success_rates(backend, "pour", load_model(directory).model, 2, 0)
    finally:
        backend.close()
    assert (summary["theta_success"], summary["random_success"]) == expected
    assert 2 <= len(summary["trials"]) <= 4
    assert all(t["cpu_s"] > 0 for t in summary["trials"])
    assert summary["theta_wilson95"][0] <= summary["theta_success"] <= \
        summary["theta_wilson95"][1]


def _close(a: object, b: object) -> bool:
    """Equal JSON values, floats to a relative 1e-12."""
    if isinstance(a, float) or isinstance(b, float):
        return isinstance(a, int | float) and isinstance(b, int | float) and math.isclose(
            a, b, rel_tol=1e-12, abs_tol=1e-15)
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b, strict=True))
    return a == b
