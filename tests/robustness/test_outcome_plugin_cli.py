"""Round 3, through the CLI: a plugin skill ltamp has never seen that reports an outcome
(a toss: the ball lands at the speed, the goal is the context), whose declared score
function fails at far goals (raises, or returns NaN). ``ltamp train`` relabels every trial
for drawn goals; before the fix the raising function ended it with a traceback (exit 1) and
the NaN one with exit 2 after the first trial was saved, and so did every resume. Now it
trains (exit 0) with one warning line, and the model samples."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

MODULE = '''
import json
import os

import numpy as np

from ltamp_cli.backends.protocol import OutcomeSpec, ParamSpace, SkillSpec, TrialResult

MODE = json.loads(open(os.environ["LTAMP_TOSS_CONFIG"]).read())["score"]


def score(contexts, controls, outcomes):
    far = contexts[:, 0] > 5.0
    if MODE == "raise" and far.any():
        raise RuntimeError("no score beyond 5 m")
    values = 0.5 - np.abs(outcomes[:, 0] - contexts[:, 0])
    if MODE == "nan":
        values[far] = np.nan
    return values


class TossBackend:
    name = "tossplug"

    def __init__(self, **options):
        self.spec = SkillSpec(
            "toss", ParamSpace(("goal",), (0.0,), (10.0,), ("m",)),
            ParamSpace(("speed",), (0.0,), (10.0,), ("m/s",)), deterministic=True,
            outcome=OutcomeSpec(ParamSpace(("landing",), (0.0,), (10.0,), ("m",)), score,
                                (0,), achieved_goal=lambda o: o))

    def skills(self):
        return {"toss": self.spec}

    def sample_context(self, skill, rng):
        return rng.uniform(0.5, 1.5, size=1)

    def is_valid(self, skill, context, controls):
        return np.ones(len(np.atleast_2d(controls)), dtype=bool)

    def run_trial(self, skill, context, control, seed):
        landing = float(control[0])
        return TrialResult(0.5 - abs(landing - float(context[0])), True, {},
                           outcome=(landing,))

    def close(self):
        pass


def make_backend(**options):
    return TossBackend(**options)
'''


def install(site: Path) -> None:
    (site / "ltamp_tossplug").mkdir(parents=True)
    (site / "ltamp_tossplug" / "__init__.py").write_text(MODULE)
    info = site / "ltamp_tossplug-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: ltamp-tossplug\n"
                                   "Version: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[ltamp.backends]\ntossplug = ltamp_tossplug:make_backend\n")


@pytest.mark.parametrize("mode", ["raise", "nan"])
def test_train_survives_a_score_function_failing_at_far_goals(tmp_path: Path,
                                                              mode: str) -> None:
    site = tmp_path / "site"
    install(site)
    (tmp_path / "toss.json").write_text(json.dumps({"score": mode}))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), str(REPO)]),
           "LTAMP_TOSS_CONFIG": str(tmp_path / "toss.json"), "OMP_NUM_THREADS": "1",
           "XDG_CACHE_HOME": str(tmp_path / "cache")}
    out = tmp_path / "model"
    train = subprocess.run(
        [sys.executable, "-m", "ltamp_cli", "train", "toss", "--backend", "tossplug",
         "--budget", "10", "--strategy", "gp", "--out", str(out)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
    assert train.returncode == 0, train.stderr[-800:]
    warnings = [line for line in train.stderr.splitlines() if "warning" in line]
    assert len(warnings) == 1 and "'toss'" in warnings[0], train.stderr[-800:]
    assert "Traceback" not in train.stderr
    assert len((out / "trials.jsonl").read_text().splitlines()) == 10
    sample = subprocess.run(
        [sys.executable, "-m", "ltamp_cli", "sample", str(out), "--context", "goal=2",
         "-n", "3", "--json"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert sample.returncode == 0, sample.stderr[-800:]
