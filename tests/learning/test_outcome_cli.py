"""A plugin skill with an outcome, never seen by ltamp, through the CLI (issue #21):
``ltamp train`` then ``--refit`` fit the trials and their relabelled points; ``train --ask``
and ``ltamp tell --outcome`` do too; a wrong outcome is refused in one line (exit 2).

The plugin (package ``ltamp_toss``, entry point ``toss`` of group ``ltamp.backends``) is
written into a temporary folder on the subprocesses' ``PYTHONPATH``; nothing is installed.
Its skill is ``test_outcomes.py``'s toss: land a ball (at ``speed`` m) within 0.5 m of the
goal; its context draws only goals near 1 m.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

MODULE = '''
import numpy as np

from ltamp_cli.backends.protocol import OutcomeSpec, ParamSpace, SkillSpec, TrialResult


def _score(contexts, controls, outcomes):
    return 0.5 - np.abs(outcomes[:, 0] - contexts[:, 0])


SPEC = SkillSpec(
    name="toss", context=ParamSpace(("goal",), (0.0,), (10.0,), ("m",)),
    control=ParamSpace(("speed",), (0.0,), (10.0,), ("m/s",)), deterministic=True,
    outcome=OutcomeSpec(space=ParamSpace(("landing",), (0.0,), (10.0,), ("m",)),
                        score=_score, goals=(0,), achieved_goal=lambda o: o))


class TossBackend:
    name = "toss"

    def skills(self):
        return {"toss": SPEC}

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
    return TossBackend()
'''


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    site = tmp_path_factory.mktemp("toss") / "site"
    (site / "ltamp_toss").mkdir(parents=True)
    (site / "ltamp_toss" / "__init__.py").write_text(MODULE)
    info = site / "ltamp_toss-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: ltamp-toss\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[ltamp.backends]\ntoss = ltamp_toss:make_backend\n")
    return site


def ltamp(site: Path, cwd: Path, *argv: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), str(REPO)]),
           "OMP_NUM_THREADS": "1", "XDG_CACHE_HOME": str(cwd / "cache")}
    return subprocess.run([sys.executable, "-m", "ltamp_cli", *argv], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600, check=False)


def ok(done: subprocess.CompletedProcess[str]) -> dict:
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout)


def test_train_refit_and_ask_tell_use_the_outcome(site: Path, tmp_path: Path) -> None:
    model = tmp_path / "model"
    ok(ltamp(site, tmp_path, "train", "toss", "--backend", "toss", "--budget", "12",
             "--init", "4", "--out", str(model), "--json"))
    trained = json.loads((model / "model.json").read_text())
    assert trained["n_train"] > 12 and trained["data_candidates"] is True
    assert trained["training"]["hindsight"]["goals"] == 4
    refit = ok(ltamp(site, tmp_path, "train", "toss", "--out", str(model), "--refit",
                     "--json"))
    assert refit["n_trials"] == 12
    refitted = json.loads((model / "model.json").read_text())
    assert refitted["n_train"] == trained["n_train"]  # trials + the same relabelled points
    assert refitted["data_candidates"] is True

    asked = tmp_path / "asked"
    for round_ in range(2):
        proposal = ok(ltamp(site, tmp_path, "train", "toss", "--backend", "toss", "--ask",
                            "--init", "2", "--out", str(asked), "--json"))
        landing = proposal["control"]["speed"]
        score = 0.5 - abs(landing - proposal["context"]["goal"])
        if round_ == 0:  # an outcome that does not give the told score: refused
            bad = ltamp(site, tmp_path, "tell", str(asked), "--score", str(score),
                        "--outcome", str(landing + 2.0))
            assert bad.returncode == 2 and "--outcome" in bad.stderr
            assert "Traceback" not in bad.stderr
            assert len(bad.stderr.strip().splitlines()) == 1
        told = ok(ltamp(site, tmp_path, "tell", str(asked), "--score", str(score),
                        "--outcome", str(landing), "--json"))
        assert told["outcome"] == [landing]
    lines = (asked / "trials.jsonl").read_text().splitlines()
    assert [json.loads(line)["outcome"] for line in lines] == [
        [json.loads(line)["control"][0]] for line in lines]
    saved = json.loads((asked / "model.json").read_text())
    assert saved["n_train"] > 2 and saved["training"]["hindsight"] is not None
