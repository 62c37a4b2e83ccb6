"""A separate package adds a backend and skill through the ``ltamp.backends`` entry point.

The example plugin in ``tests/plugins/slide_plugin`` is installed with pip into a temporary
folder (never into the venv), which the ``ltamp`` subprocesses see on ``PYTHONPATH``. Its
skill is then listed, collected, imported, trained, evaluated, sampled and used by a learned
stream in a solve whose plan its executor replays.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
PLUGIN_SOURCE = Path(__file__).resolve().parent / "slide_plugin"
TIMEOUT_S = 240


@pytest.fixture(scope="module")
def plugin_site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The plugin installed (pip, no dependencies) into a fresh folder; returns the folder."""
    work = tmp_path_factory.mktemp("plugin")
    source = work / "source"  # pip builds in the source tree: build from a copy
    shutil.copytree(PLUGIN_SOURCE, source, ignore=shutil.ignore_patterns("__pycache__"))
    site = work / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--no-build-isolation", "--no-index", "--disable-pip-version-check",
                    "--target", str(site), str(source)], check=True, timeout=TIMEOUT_S,
                   capture_output=True)
    return site


def ltamp(site: Path, cwd: Path, *argv: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), str(REPO_ROOT)]),
               XDG_CACHE_HOME=str(cwd / "cache"), OMP_NUM_THREADS="1")
    return subprocess.run([sys.executable, "-m", "ltamp_cli", *argv], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=TIMEOUT_S, check=False)


def ok_json(done: subprocess.CompletedProcess[str]) -> dict:
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout)


def test_without_the_plugin_the_backend_is_unknown(tmp_path: Path) -> None:
    done = ltamp(tmp_path, tmp_path, "collect", "push", "--backend", "slide", "-n", "1",
                 "--out", str(tmp_path / "t.jsonl"))
    assert done.returncode == 2
    assert "unknown backend 'slide'" in done.stderr and "Traceback" not in done.stderr


@pytest.mark.slow
def test_plugin_skill_is_collected_trained_sampled_and_solved(plugin_site: Path,
                                                              tmp_path: Path) -> None:
    sys.path.insert(0, str(plugin_site))
    try:
        from ltamp_slide import SlideBackend  # the installed copy, to check outcomes
    finally:
        sys.path.remove(str(plugin_site))
    truth = SlideBackend()

    listing = ok_json(ltamp(plugin_site, tmp_path, "skills", "--json"))
    slide = {b["name"]: b for b in listing["backends"]}["slide"]
    assert slide["available"] and [s["name"] for s in slide["skills"]] == ["push"]

    collected = ok_json(ltamp(plugin_site, tmp_path, "collect", "push", "--backend", "slide",
                              "-n", "40", "--out", "pool.jsonl", "--json"))
    assert collected["added"] == 40
    records = [json.loads(line) for line in (tmp_path / "pool.jsonl").read_text().splitlines()]
    assert len(records) == 40 and {r["backend"] for r in records} == {"slide"}

    rows = ["target,speed,score"] + [
        f"{t},{v},{truth.run_trial('push', np.array([t]), np.array([v]), 0).score}"
        for t, v in ((2.0, 2.0), (2.0, 3.5), (4.0, 2.8))]
    (tmp_path / "recorded.csv").write_text("\n".join(rows) + "\n")
    imported = ok_json(ltamp(plugin_site, tmp_path, "import", "recorded.csv", "--skill", "push",
                             "--backend", "slide", "--out", "recorded.jsonl", "--json"))
    assert imported["added"] == 3

    trained = ok_json(ltamp(plugin_site, tmp_path, "train", "push", "--backend", "slide",
                            "--budget", "30", "--init", "8", "--seed", "0", "--out", "model",
                            "--json"))
    assert trained["kind"] == "gp" and trained["n_trials"] == 30
    pooled = ok_json(ltamp(plugin_site, tmp_path, "train", "push", "--backend", "slide",
                           "--data", "pool.jsonl", "--budget", "40", "--out", "pooled",
                           "--json"))
    assert pooled["n_trials"] == 40

    evaluated = ok_json(ltamp(plugin_site, tmp_path, "evaluate", "model", "--trials", "20",
                              "--json"))
    assert evaluated["backend"] == "slide" and evaluated["success_rate"] >= 0.8
    for rate in ("success_rate", "random_success_rate"):  # live trials: both with intervals
        low, high = evaluated[f"{rate}_wilson95"]
        assert low <= evaluated[rate] <= high and high - low > 0.1

    sampled = ok_json(ltamp(plugin_site, tmp_path, "sample", "model", "--context",
                            "target=3.0", "-n", "20", "--json"))
    speeds = [s["speed"] for s in sampled["samples"]]
    good = [truth.run_trial("push", np.array([3.0]), np.array([v]), 7).score > 0
            for v in speeds]
    assert len(speeds) == 20 and sum(good) >= 16  # good speeds: about [2.1, 2.8] m/s

    domain = plugin_site / "ltamp_slide" / "domain"
    (tmp_path / "problem.yaml").write_text(
        f"domain: {domain}\nbindings: {domain / 'streams.py'}\n"
        f"world:\n  learned_streams:\n    sample-push: {{model: {tmp_path / 'model'}, "
        "sampler: adaptive}\n"
        "objects: {t1: 2.0, t2: 4.5}\ninit: [(Target t1), (Target t2)]\n"
        "goal: (and (Reached t1) (Reached t2))\n")
    solved = ok_json(ltamp(plugin_site, tmp_path, "solve", "problem.yaml", "--seed", "0",
                           "--backend", "slide", "--json"))
    assert solved["status"] == "solved" and solved["executed"] and solved["goal_holds"]
    assert [step["target"] for step in solved["execution"]["steps"]] in ([2.0, 4.5],
                                                                        [4.5, 2.0])
