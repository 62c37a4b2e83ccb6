"""``ltamp plot level-set``: a real GP trained on the synthetic moving2d skill, drawn as PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ltamp_cli.cli.app import main
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.sampling.level_set_plot import DPI, FIGSIZE_IN, slice_grid
from ltamp_cli.sampling.superlevel import build_superlevel_set

EXPECTED_SIZE = (round(FIGSIZE_IN[0] * DPI), round(FIGSIZE_IN[1] * DPI))


def run(argv: list[str]) -> int:
    with pytest.raises(SystemExit) as done:
        main(argv)
    return int(done.value.code or 0)


@pytest.fixture(scope="module")
def model_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("moving2d") / "model"
    assert run(["train", "moving2d", "--budget", "25", "--init", "10", "--seed", "0",
                "--out", str(out)]) == 0
    return out


def pixels(path: Path) -> np.ndarray:
    with Image.open(path) as image:
        assert image.format == "PNG"
        assert image.size == EXPECTED_SIZE
        return np.asarray(image.convert("RGB"), dtype=np.int16)


def test_level_set_png_has_the_right_size_and_content(model_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "pics" / "level.png"
    assert run(["plot", "level-set", str(model_dir), "--context", "phase=0.5", "--dims", "x,y",
                "--out", str(out)]) == 0
    image = pixels(out)
    not_white = np.any(image < 245, axis=-1).mean()
    colours = len(np.unique(image.reshape(-1, 3), axis=0))
    assert not_white > 0.4  # the colour map fills most of the axes
    assert colours > 200  # a continuous μ/σ map, not a flat fill


def test_swapping_dims_transposes_the_picture(model_dir: Path, tmp_path: Path) -> None:
    first, second = tmp_path / "xy.png", tmp_path / "yx.png"
    for dims, out in (("x,y", first), ("1,0", second)):
        assert run(["plot", "level-set", str(model_dir), "--context", "phase=0.2",
                    "--dims", dims, "--samples", "0", "--out", str(out)]) == 0
    assert np.abs(pixels(first) - pixels(second)).mean() > 5.0


def test_slice_passes_through_theta_star(model_dir: Path) -> None:
    model = load_model(model_dir).model
    superlevel = build_superlevel_set(model, np.array([0.5]), np.random.default_rng(0))
    u = slice_grid(superlevel, (0, 1), size=41)
    assert u.shape == (41 * 41, 2)
    # The trained set is not empty at this context: the slice contains members.
    assert superlevel.ratio(u).max() > superlevel.beta


@pytest.mark.parametrize(("extra", "message"), [
    (["--dims", "0,5"], "--dims: index 5 out of range"),
    (["--dims", "x,x"], "must differ"),
    (["--dims", "x,z"], "neither a control index"),
    (["--context", "phase=3"], "outside the trained range"),
    (["--out", "picture.jpg"], "expected a .png"),
])
def test_bad_input_exits_2_with_one_line(model_dir: Path, tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str],
                                         extra: list[str], message: str) -> None:
    argv = ["plot", "level-set", str(model_dir), "--context", "phase=0.5",
            "--out", str(tmp_path / "p.png")]
    # Each case replaces the option it breaks rather than repeating it.
    if "--context" in extra:
        argv = ["plot", "level-set", str(model_dir), "--out", str(tmp_path / "p.png")]
    if "--out" in extra:
        argv = ["plot", "level-set", str(model_dir), "--context", "phase=0.5"]
    assert run([*argv, *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err
    assert "\n" not in err and "Traceback" not in err
    assert not (tmp_path / "p.png").exists()
