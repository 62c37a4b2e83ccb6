"""Kitchen2D animations: the view follows the pushed block and shows the goal; executions
are captioned with the running action and timed as asked (``--fps``/``--speed``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageSequence

from ltamp_cli.backends.box2d.backend import render_trial
from ltamp_cli.backends.box2d.render import FrameRecorder, follow_view
from ltamp_cli.backends.frames import caption_height
from ltamp_cli.cli.app import main

ROOT = Path(__file__).resolve().parents[2]
SERVE = ROOT / "problems" / "kitchen2d" / "fill_and_serve.yaml"
BLOCK = (200, 80, 60)
GOAL = (40, 170, 60)

#: A push away from the goal (at x = 4.5) that slides the block ~10 units to the left.
CONTEXT = np.array([4.5, 0.0])
CONTROL = np.array([1.5, 0.0, math.pi, 2.0])


def has_colour(image: Image.Image | np.ndarray, rgb: tuple[int, int, int]) -> bool:
    pixels = np.asarray(image.convert("RGB") if isinstance(image, Image.Image) else image)
    return bool(np.all(np.abs(pixels.astype(int) - rgb) <= 3, axis=-1).sum() >= 4)


def gif_frames(path: Path) -> list[tuple[np.ndarray, int]]:
    with Image.open(path) as gif:
        return [(np.asarray(f.convert("RGB"), dtype=int), int(f.info["duration"]))
                for f in ImageSequence.Iterator(gif)]


def test_the_push_view_follows_the_block_and_always_shows_the_goal(tmp_path: Path) -> None:
    result, frames = render_trial("push", CONTEXT, CONTROL, 0, tmp_path / "push.gif")
    assert result.valid and result.info  # a real trial ran
    assert len(frames) > 20
    assert {f.size for f in frames} == {frames[0].size} and frames[0].size >= (640, 480)
    assert all(has_colour(f, BLOCK) and has_colour(f, GOAL) for f in frames)
    # Not vacuous: a view fixed at the first frame loses the block.
    recorder = FrameRecorder(every=5, scale=30.0)
    from ltamp_cli.backends.box2d.backend import Kitchen2DBackend

    Kitchen2DBackend().run_trial("push", CONTEXT, CONTROL, 0, observer=recorder)
    assert not has_colour(recorder.frames[-1], BLOCK)
    # The saved GIF is captioned with the skill and its parameters.
    pictures = gif_frames(tmp_path / "push.gif")
    band = caption_height(*pictures[0][0].shape[:2])
    assert all(np.median(picture[-band:]) < 60 for picture, _ in pictures)


def test_follow_view_keeps_the_pixel_size_and_shows_all_content() -> None:
    for content in ((0.0, 0.0, 1.0, 1.0), (-30.0, -2.0, 30.0, 2.0), (5.0, -40.0, 6.0, 40.0)):
        view = follow_view(content, (640, 480), max_scale=30.0, reserve_px=40)
        x0, y0, x1, y1 = view.bounds
        assert round((x1 - x0) * view.scale) == 640 and round((y1 - y0) * view.scale) == 480
        assert x0 <= content[0] and content[2] <= x1 and content[3] <= y1
        assert y0 + 40 / view.scale <= content[1] + 1e-9  # above the caption strip
        assert view.scale <= 30.0


def test_cli_fps_and_speed_need_render_and_sane_values(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture) -> None:
    for argv, word in ((["--fps", "5"], "--fps"), (["--speed", "2"], "--speed"),
                       (["--render", str(tmp_path / "x.gif"), "--fps", "0"], "--fps"),
                       (["--render", str(tmp_path / "x.gif"), "--speed", "-1"], "--speed")):
        with pytest.raises(SystemExit) as bad:
            main(["solve", str(SERVE), "--backend", "box2d", "--max-time", "5", *argv])
        assert bad.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and word in err[0]
