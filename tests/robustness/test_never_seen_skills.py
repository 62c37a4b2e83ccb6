"""Skills ltamp has never seen, through the Python API (a plugin module imported directly)
and through the CLI (the same module as an ``ltamp.backends`` entry point).

"Sensibly" is spelled out per test: a learned set that should exist is found (θ* and most
samples succeed in the plugin's own physics); one that cannot be learned is refused in one
line, or reported as empty, never sampled as if it were there.
"""

from __future__ import annotations

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
