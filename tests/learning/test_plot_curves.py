"""``ltamp plot curves``: every strategy's F1 and success-rate curve on one PNG (+ JSON)."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib
import numpy as np
import pytest
from matplotlib.image import imread

from ltamp_cli.cli.app import main

# matplotlib's default colour cycle: learner k (sorted by name) is drawn in CYCLE[k]
CYCLE = [matplotlib.colors.to_rgb(c["color"])
         for c in matplotlib.rcParams["axes.prop_cycle"]][:4]


def run(capsys: pytest.CaptureFixture[str], *args: str | Path) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as done:
        main([*map(str, args)])
    out, err = capsys.readouterr()
    return int(done.value.code or 0), out, err


def colour_pixels(png: Path, rgb: tuple[float, float, float]) -> int:
    image = imread(png)[..., :3]
    return int(np.all(np.abs(image - np.array(rgb)) < 1.5 / 255, axis=-1).sum())


def check_picture(png: Path, learners: list[str]) -> dict:
    image = imread(png)
    # two panels of 5.5 x 4 inches at 100 dpi
    assert image.shape[:2] == (400, 1100)
    assert float(image[..., :3].std()) > 0.05  # not blank
    data = json.loads(png.with_suffix(".json").read_text())
    assert data["learners"] == learners
    for k in range(len(learners)):
        assert colour_pixels(png, CYCLE[k]) > 30, (k, learners[k])
    assert colour_pixels(png, CYCLE[len(learners)]) == 0  # no extra line
    return data


def test_curves_from_saved_models(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    runs = []
    for strategy, seed in (("random", 0), ("random", 1), ("gp", 0)):
        directory = tmp_path / f"{strategy}{seed}"
        code, out, err = run(capsys, "train", "toy1d", "--backend", "synthetic", "--strategy",
                             strategy, "--budget", "12", "--init", "4", "--eval-every", "4",
                             "--seed", str(seed), "--out", directory)
        assert code == 0, err
        runs.append(directory)
    png = tmp_path / "pictures" / "curves.png"
    code, out, err = run(capsys, "plot", "curves", *runs, "--out", png)
    assert code == 0, err
    assert str(png) in out
    data = check_picture(png, ["gp", "random"])
    saved = json.loads((runs[2] / "model.json").read_text())["curve"]
    gp_rows = [r for r in data["rows"] if r["learner"] == "gp"]
    assert [(r["n_trials"], r["f1"]) for r in gp_rows] == [
        (p["n_trials"], p["f1"]) for p in saved]
    # the two random runs are averaged per number of trials
    random_summary = [e for e in data["summary"] if e["learner"] == "random"]
    assert [e["n_trials"] for e in random_summary] == [4, 8, 12]
    assert all(e["f1_count"] == 2 for e in random_summary)


@pytest.mark.slow
def test_curves_by_training_strategies(tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    png = tmp_path / "curves.png"
    code, _, err = run(capsys, "plot", "curves", "--strategies", "lse2,random,gp", "--skill",
                         "toy1d", "--budget", "15", "--eval-every", "5", "--out", png)
    assert code == 0, err
    data = check_picture(png, ["gp", "lse2", "random"])
    final = {e["learner"]: e for e in data["summary"] if e["n_trials"] == 15}
    # a GP learns the 1-D toy's level set from 15 trials; the constant baseline cannot
    assert final["lse2"]["f1_mean"] > 0.8 and final["random"]["f1_mean"] < 0.2


@pytest.mark.parametrize(("args", "fragment"), [
    (["--out", "c.png"], "give model directories or --strategies"),
    (["--strategies", "lse9", "--out", "c.png"], "--strategies: expected names from"),
    (["--strategies", "lse2", "--out", "c.txt"], "--out: expected a .png file name"),
    (["--strategies", "lse2", "--budget", "0", "--out", "c.png"], "--budget: expected"),
    (["--strategies", "lse2", "--skill", "fly", "--out", "c.png"], "no skill 'fly'"),
])
def test_bad_options_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                  args: list[str], fragment: str) -> None:
    args = [str(tmp_path / a) if a.startswith("c.") else a for a in args]
    code, _, err = run(capsys, "plot", "curves", *args)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0], err
    assert not list(tmp_path.iterdir())


def test_model_without_curve_is_reported(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    directory = tmp_path / "m"
    code, _, err = run(capsys, "train", "toy1d", "--backend", "synthetic", "--strategy",
                       "random", "--budget", "5", "--init", "5", "--out", directory)
    assert code == 0, err
    code, _, err = run(capsys, "plot", "curves", directory, "--out", tmp_path / "c.png")
    assert code == 2
    assert err.strip().splitlines() == [
        f"ltamp: error: {directory}: no learning curve saved: train with --eval-every K or "
        "--curve FILE"]
