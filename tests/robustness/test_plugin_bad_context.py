"""A plugin whose ``sample_context`` returns NaN, one value too few or a value outside its
own context box: ``collect``, ``train`` and ``evaluate`` refuse in one line naming the
backend, its module and what was expected (exit 2), and nothing is recorded.

Before the fix this surfaced as a ValueError traceback from numpy (``cannot reshape``) or,
for NaN, as trials with a NaN context that the trial file then refused.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from odd_plugin import install_odd_plugin, odd_env

CONFIG = {"context": [["a", 0.0, 1.0]], "control": [["u", 0.0, 1.0]], "score": "ball"}


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return install_odd_plugin(tmp_path_factory.mktemp("odd") / "site")


def _ltamp(site: Path, config: dict, cwd: Path, *argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "ltamp_cli", *argv], cwd=cwd,
                          env=odd_env(site, config, cwd), capture_output=True, text=True,
                          timeout=600, check=False)


def _refused(done: subprocess.CompletedProcess[str]) -> str:
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1, done.stderr[-1500:]
    assert lines[0].startswith("ltamp: error: backend 'odd' (ltamp_odd): sample_context")
    assert "expected 1 finite number(s) (a) inside the skill's context bounds" in lines[0]
    return lines[0]


@pytest.mark.parametrize("draw", ["nan", "short", "outside"])
def test_a_bad_drawn_context_is_one_line(site: Path, tmp_path: Path, draw: str) -> None:
    config = {**CONFIG, "context_draw": draw}
    _refused(_ltamp(site, config, tmp_path, "collect", "odd", "--backend", "odd", "-n", "5",
                    "--out", "t.jsonl"))
    assert not (tmp_path / "t.jsonl").exists() or not (tmp_path / "t.jsonl").read_text()
    _refused(_ltamp(site, config, tmp_path, "train", "odd", "--backend", "odd", "--budget",
                    "6", "--init", "3", "--out", "m"))
    trials = tmp_path / "m" / "trials.jsonl"
    assert not trials.exists() or not trials.read_text()


def test_evaluate_refuses_a_bad_drawn_context(site: Path, tmp_path: Path) -> None:
    trained = _ltamp(site, CONFIG, tmp_path, "train", "odd", "--backend", "odd", "--budget",
                     "8", "--init", "4", "--out", "m")
    assert trained.returncode == 0, trained.stderr[-1500:]
    _refused(_ltamp(site, {**CONFIG, "context_draw": "short"}, tmp_path, "evaluate", "m",
                    "--trials", "3"))


def test_the_python_api_raises_the_same_error(site: Path, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    from ltamp_cli.errors import InputError
    from ltamp_cli.learning.active import LearningConfig, learn_online
    from ltamp_cli.trials.record import TrialDataset

    monkeypatch.syspath_prepend(str(site))
    env = odd_env(site, {**CONFIG, "context_draw": "nan"}, tmp_path)  # writes odd.json
    monkeypatch.setenv("LTAMP_ODD_CONFIG", env["LTAMP_ODD_CONFIG"])
    from ltamp_odd import OddBackend

    dataset = TrialDataset(tmp_path / "t.jsonl")
    with pytest.raises(InputError, match=r"expected 1 finite number\(s\) \(a\)"):
        learn_online(OddBackend(), "odd", LearningConfig(budget=4, init=2, seed=0), dataset)
    assert dataset.read() == []
