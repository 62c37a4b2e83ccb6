"""Skills ltamp has never seen, through the Python API (a plugin module imported directly)
and through the CLI (the same module as an ``ltamp.backends`` entry point).

"Sensibly" is spelled out per test: a learned set that should exist is found (θ* and most
samples succeed in the plugin's own physics); one that cannot be learned is refused in one
line, or reported as empty, never sampled as if it were there.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))

from odd_plugin import install_odd_plugin, odd_env

from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.sampling.factory import make_sampler
from ltamp_cli.trials.record import TrialDataset

BALL = {"context": [["a", 0.0, 1.0]], "control": [["u", 0.0, 1.0]], "score": "ball"}


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return install_odd_plugin(tmp_path_factory.mktemp("odd") / "site")


def _backend(site: Path, config: dict[str, Any], where: Path,
             monkeypatch: pytest.MonkeyPatch) -> Any:
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.setenv("LTAMP_ODD_CONFIG", odd_env(site, config, where)["LTAMP_ODD_CONFIG"])
    from ltamp_odd import OddBackend

    return OddBackend()


def _ltamp(site: Path, config: dict, cwd: Path, *argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "ltamp_cli", *argv], cwd=cwd,
                          env=odd_env(site, config, cwd), capture_output=True, text=True,
                          timeout=600, check=False)


@pytest.mark.parametrize("score_type", ["float", "int", "bool", "numpy", "0d"])
def test_any_real_score_type_learns_the_same_set(site: Path, tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch,
                                                 score_type: str) -> None:
    """Sensibly: every trial is recorded with a float score whose sign is the true outcome
    (a bool score is a label: True -> +1, False -> -1), and after 20 trials θ* and at least
    80 % of 30 samples lie in the success interval |u - 0.5| < 0.3 (before the fix a bool
    score recorded failures as 0.0, on the level: θ* and the samples missed the interval)."""
    backend = _backend(site, {**BALL, "score_type": score_type}, tmp_path, monkeypatch)
    dataset = TrialDataset(tmp_path / "t.jsonl")
    result = learn_online(backend, "odd", LearningConfig(budget=20, init=6, seed=1), dataset)
    records = dataset.read()
    assert len(records) == 20 and all(r.valid for r in records)
    for record in records:
        truth = abs(record.control[0] - 0.5) < 0.3
        assert isinstance(record.score, float) and (record.score > 0) == truth
    model = result.model
    assert isinstance(model, LevelSetModel)
    rng = np.random.default_rng(0)
    inside = 0
    for a in (0.1, 0.5, 0.9):
        star, _ = model.most_confident_control(np.array([a]), rng)
        assert abs(star[0] - 0.5) < 0.3, (a, star)
        sampler = make_sampler("adaptive", model, np.array([a]), rng)
        inside += sum(abs(next(sampler)[0] - 0.5) < 0.3 for _ in range(10))
    assert inside >= 24, inside


@pytest.mark.parametrize("context, control, expected", [
    ([["a", 0, 1]], [["a", 0, 1], ["v", 0, 1]], "the name 'a' is used twice"),
    ([["a", 0, 1]], [["u", 0, 1], ["u", 0, 1]], "the name 'u' is used twice"),
    ([["a", 0, 1]], [["u", 0, "NaN"]], "expected finite numbers"),
    ([["a", -1e308, 1e308]], [["u", 0, 1]], "with a finite width"),
    ([["", 0, 1]], [["u", 0, 1]], "non-empty strings"),
])
def test_a_skill_no_model_could_hold_is_refused_before_any_trial(
        site: Path, tmp_path: Path, context: list, control: list, expected: str) -> None:
    """Sensibly: refused in one line naming the backend before a trial runs. Before the fix
    duplicate names trained 20 trials into a model that `evaluate`/`sample` then refused
    ("the name 'a' is used twice"); NaN bounds were accepted."""
    config = {"context": context, "control": control, "score": "ball"}
    config = json.loads(json.dumps(config).replace('"NaN"', "NaN"))
    done = _ltamp(site, config, tmp_path, "train", "odd", "--backend", "odd", "--budget", "6",
                  "--init", "3", "--out", "m")
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1, done.stderr[-1500:]
    assert lines[0].startswith("ltamp: error: backend 'odd' (ltamp_odd): skill 'odd'")
    assert expected in lines[0], lines
    assert not (tmp_path / "m" / "trials.jsonl").exists()


def test_collect_and_skills_with_a_refused_skill(site: Path, tmp_path: Path) -> None:
    config = {"context": [["a", 0, 1]], "control": [["a", 0, 1]], "score": "ball"}
    done = _ltamp(site, config, tmp_path, "collect", "odd", "--backend", "odd", "-n", "3",
                  "--out", "t.jsonl")
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1 and "used twice" in lines[0], lines
    assert not (tmp_path / "t.jsonl").exists()
    listing = _ltamp(site, config, tmp_path, "skills", "--json")  # the others still listed
    assert listing.returncode == 0, listing.stderr[-800:]
    names = {b["name"] for b in json.loads(listing.stdout)["backends"]}
    assert {"synthetic", "odd"} <= names


@pytest.mark.parametrize("score", ["fail", "point"])
def test_a_skill_never_seen_to_succeed_is_sampled_as_a_guess_with_a_warning(
        site: Path, tmp_path: Path, score: str) -> None:
    """Sensibly: the model of a skill whose 20 trials all failed (always failing, or
    succeeding only at one exact control) has θ* with μ/σ <= 0; `sample` still returns the
    least bad controls (finite β, around θ*) but warns in one line that nothing is
    predicted to succeed, and `evaluate` reports a success rate of 0. Before the fix the
    relaxed β of an all-fail model was -inf (Φ⁻¹ of an underflowed Φ(φ*)), so the "set" was
    the whole box, without a word."""
    config = {**BALL, "score": score}
    trained = _ltamp(site, config, tmp_path, "train", "odd", "--backend", "odd", "--budget",
                     "20", "--init", "6", "--out", "m")
    assert trained.returncode == 0, trained.stderr[-1500:]
    done = _ltamp(site, config, tmp_path, "sample", "m", "--context", "a=0.5", "-n", "5",
                  "--json")
    assert done.returncode == 0, done.stderr[-1500:]
    result = json.loads(done.stdout)
    assert np.isfinite(result["beta"]) and result["phi_star"] <= 0
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "predicts failure at every control" in lines[0], lines
    evaluated = _ltamp(site, config, tmp_path, "evaluate", "m", "--trials", "5", "--json")
    assert evaluated.returncode == 0 and json.loads(evaluated.stdout)["success_rate"] == 0.0


def test_relaxed_beta_stays_finite_far_below_the_level() -> None:
    from ltamp_cli.learning.confidence import relaxed_beta

    for phi in (-10.0, -40.0, -1e3):
        beta = relaxed_beta(phi, 0.95)
        assert np.isfinite(beta) and phi - 0.01 < beta < phi  # just below φ*
    assert abs(relaxed_beta(5.0, 0.95) - 1.6449) < 1e-3  # unchanged where Φ(φ*) ≈ 1


SHAPES = {
    "12-D control": {"context": [["a", 0.0, 1.0]],
                     "control": [[f"u{i}", -1.0, 1.0] for i in range(12)]},
    "no context": {"context": [], "control": [["u", 0, 1], ["v", 0, 1]]},
    "context lo == hi": {"context": [["a", 0.5, 0.5], ["b", 0, 1]], "control": [["u", 0, 1]]},
    "1e-9 wide": {"context": [["a", 0.0, 1e-9]], "control": [["u", 0.0, 1e-9], ["v", 0, 1e-9]]},
    "1e9 wide": {"context": [["a", 0.0, 1e9]], "control": [["u", -1e9, 0.0], ["v", 0, 1e9]]},
    "unicode names": {"context": [["α-β", 0, 1]], "control": [["θ 角", 0, 1], ["ü", 0, 1]]},
}


@pytest.mark.parametrize("shape", sorted(SHAPES))
def test_unusual_skill_shapes_learn_save_load_and_sample(site: Path, tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch,
                                                         shape: str) -> None:
    """Sensibly: 20 lse trials, saved and loaded back (names and bounds intact), give a θ*
    that succeeds in the plugin's physics at three contexts of the box (its ends and middle)
    and adaptive samples that lie in the control box; where the success interval is 60 % of
    the first control's range (all shapes but 12-D), at least 70 % of 30 samples succeed."""
    from ltamp_cli.learning.model_dir import load_model, save_model

    config = {**SHAPES[shape], "score": "ball"}
    backend = _backend(site, config, tmp_path, monkeypatch)
    spec = backend.spec
    result = learn_online(backend, "odd", LearningConfig(budget=20, init=6, seed=3))
    save_model(result.model, tmp_path / "m")
    model = load_model(tmp_path / "m").model
    assert isinstance(model, LevelSetModel) and model.spec == spec
    lows, highs = spec.control.low_array(), spec.control.high_array()
    rng = np.random.default_rng(0)
    successes = drawn = 0
    for fraction in (0.0, 0.5, 1.0):
        context = spec.context.low_array() + fraction * (spec.context.high_array()
                                                         - spec.context.low_array())
        star, _ = model.most_confident_control(context, rng)
        assert backend.success(star) > 0, (fraction, star)
        sampler = make_sampler("adaptive", model, context, rng)
        for _ in range(10):
            control = next(sampler)
            assert np.all(control >= lows) and np.all(control <= highs)
            successes += backend.success(control) > 0
            drawn += 1
    if shape != "12-D control":
        assert successes >= 0.7 * drawn, (successes, drawn)
