"""``python -m bench.paper --smoke`` writes every experiment's JSON (with its keys), non-blank
PNGs and the Markdown report, into a temporary folder (never into the repository)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

# experiment -> keys its JSON must have besides the common ones
EXPECTED = {
    "al2d": {"skills", "learners", "runs"},
    "supervised3d": {"skills", "backend"},
    "active3d": {"skills", "backend"},
    "sampling": {"tables", "samplers", "lambda"},
    "kernel_learning": {"rows", "sampler_labels"},
    "confident": {"table", "backend"},
    "coffee": {"kitchens"},
}
COMMON = {"experiment", "mode", "machine", "wall_s", "sizes", "pngs"}


def _non_blank(path: Path) -> bool:
    import matplotlib.image

    pixels = np.asarray(matplotlib.image.imread(path), dtype=float)[..., :3]
    # A blank figure is one flat colour; real plots have lines, bars and text.
    return pixels.std() > 0.02 and np.mean(np.abs(pixels - pixels[0, 0]) > 0.1) > 0.01


@pytest.mark.slow
def test_smoke_run_writes_json_png_and_report(repo_root: Path, tmp_path: Path) -> None:
    out = tmp_path / "paper"
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
           "MKL_NUM_THREADS": "1", "MPLBACKEND": "Agg"}
    completed = subprocess.run(
        [sys.executable, "-m", "bench.paper", "--smoke", "--out", str(out)],
        cwd=repo_root, env=env, capture_output=True, text=True, timeout=900)
    assert completed.returncode == 0, completed.stdout[-2000:] + completed.stderr[-3000:]

    for name, keys in EXPECTED.items():
        data = json.loads((out / f"{name}.json").read_text())
        assert not data.get("failed"), data.get("error")
        assert COMMON | keys <= set(data), f"{name}: missing {(COMMON | keys) - set(data)}"
        assert data["mode"] == "smoke"
        assert data["pngs"], name
        for png in data["pngs"]:
            assert _non_blank(out / png), f"{name}: {png} is blank"

    al2d = json.loads((out / "al2d.json").read_text())
    rates = [e["success_rate_mean"] for e in al2d["skills"]["push"]["summary"]]
    assert rates and all(0.0 <= r <= 1.0 for r in rates)
    sampling = json.loads((out / "sampling.json").read_text())
    for table in sampling["tables"]:
        for sampler in sampling["samplers"]:
            metrics = table["metrics"][sampler]
            assert {"fp", "t50_cpu_s", "n5", "diversity"} <= set(metrics)
            assert 0.0 <= metrics["fp"]["mean"] <= 100.0
            assert 1 <= metrics["n5"]["mean"] <= 100
    coffee = json.loads((out / "coffee.json").read_text())
    assert coffee["kitchens"]["2D"]["solved"] == 1  # the shipped models solve the 2D coffee task

    report = (out / "RESULTS.md").read_text()
    for heading in ("## 1. Kitchen2D active learning", "## 2. Kitchen3D supervised",
                    "## 3. Kitchen3D active learning", "## 4. Sampling table",
                    "## 5. Kernel learning", "## 6. Most confident prediction",
                    "## 7. Integrated coffee task"):
        assert heading in report
    assert "**smoke**" in report and "Failed" not in report
    assert "](al2d.png)" in report  # figures link to the PNGs next to the report
    assert not (repo_root / "docs" / "RESULTS.md").is_file() or (
        "--smoke" not in (repo_root / "docs" / "RESULTS.md").read_text())


def test_unknown_experiment_is_one_line_exit_2(repo_root: Path, tmp_path: Path) -> None:
    completed = subprocess.run(
        [sys.executable, "-m", "bench.paper", "--smoke", "--only", "nope", "--out",
         str(tmp_path)], cwd=repo_root, capture_output=True, text=True, timeout=120)
    assert completed.returncode == 2
    assert completed.stderr.strip().count("\n") == 0
    assert "unknown experiment 'nope'" in completed.stderr
