"""``ltamp sample``: JSON output, bad input as one-line errors (exit 2), the level-set PNG."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ltamp_cli.cli.app import main


def _run(capsys, argv: list[str]) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as done:
        main(argv)
    captured = capsys.readouterr()
    return int(done.value.code or 0), captured.out, captured.err


@pytest.fixture(scope="module")
def model_dir(moving2d_model, tmp_path_factory):
    directory = tmp_path_factory.mktemp("moving2d")
    moving2d_model.save(str(directory))
    return directory


def test_sample_json(capsys, model_dir, moving2d_model) -> None:
    code, out, _ = _run(capsys, ["sample", str(model_dir), "--context", "phase=0.4", "-n", "20",
                                 "--sampler", "diverse", "--seed", "3", "--json"])
    assert code == 0
    result = json.loads(out)
    assert set(result) >= {"samples", "time_s", "beta"}
    assert len(result["samples"]) == 20
    controls = np.array([[s["x"], s["y"]] for s in result["samples"]])
    mean, std = moving2d_model.predict(np.array([0.4]), controls)
    assert np.all(mean / std > result["beta"])
    code, again, _ = _run(capsys, ["sample", str(model_dir), "--context", "phase=0.4", "-n",
                                   "20", "--sampler", "diverse", "--seed", "3", "--json"])
    assert json.loads(again)["samples"] == result["samples"]  # seeded


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--context", "phase=2"], "outside the trained range"),
        (["--context", "speed=0.1"], "unknown context 'speed'"),
        ([], "missing phase"),
        (["--context", "phase=abc"], "expected a number"),
        (["--context", "phase=0.1", "--sampler", "mcmc"], "unknown sampler"),
        (["--context", "phase=0.1", "--lambda", "0.5"], "--lambda"),
        (["--context", "phase=0.1", "--plot", "x.gif"], ".png"),
    ],
)
def test_sample_bad_input(capsys, model_dir, args: list[str], message: str) -> None:
    code, _, err = _run(capsys, ["sample", str(model_dir), *args])
    assert code == 2
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_sample_not_a_model(capsys, tmp_path) -> None:
    code, _, err = _run(capsys, ["sample", str(tmp_path), "--context", "phase=0.1"])
    assert code == 2 and "model.json" in err


@pytest.mark.parametrize("skill_model", ["moving2d_model", "toy1d_model"])
def test_sample_plot_png(capsys, request, tmp_path, skill_model: str) -> None:
    model = request.getfixturevalue(skill_model)
    directory = tmp_path / "model"
    model.save(str(directory))
    context = ["--context", "phase=0.7"] if model.spec.context.dim else []
    png = tmp_path / "out" / "set.png"
    code, out, _ = _run(capsys, ["sample", str(directory), *context, "-n", "30", "--plot",
                                 str(png), "--json"])
    assert code == 0 and json.loads(out)["plot"] == str(png)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from PIL import Image

    with Image.open(png) as image:
        pixels = np.asarray(image.convert("RGB"))
    assert image.width > 300 and pixels.std() > 10  # a drawn figure, not a blank canvas
