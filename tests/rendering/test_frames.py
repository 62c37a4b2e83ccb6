"""GIF timing (subsampling, never faster physics) and captions, on real images and files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageSequence

from ltamp_cli.backends.frames import (
    GifTiming,
    action_caption,
    action_focus,
    caption,
    caption_height,
    recording_span,
    select_frames,
    write_animation,
)

#: How the Kitchen2D executor records: a frame every 20 steps of 0.01 s.
KITCHEN2D_FRAME_S = 0.2
#: How the Kitchen3D executors record: a state every 12 steps of 1/240 s.
KITCHEN3D_FRAME_S = 12 / 240


def gif_timing(path: Path) -> tuple[int, float, tuple[int, int]]:
    """Frames, total playing time (s) and size of a GIF file."""
    with Image.open(path) as gif:
        durations = [frame.info["duration"] for frame in ImageSequence.Iterator(gif)]
        return len(durations), sum(durations) / 1000.0, gif.size


@pytest.mark.parametrize("frame_s", [KITCHEN2D_FRAME_S, KITCHEN3D_FRAME_S])
@pytest.mark.parametrize("sim_s", [5.0, 44.0, 246.0, 900.0, 3600.0])
def test_default_gifs_last_under_a_minute_whatever_the_execution_length(
        frame_s: float, sim_s: float) -> None:
    """The 2D coffee execution lasts 246 simulated seconds (3 min 47 s as a real-time GIF);
    any execution, at the executors' recording rates, plays in under a minute."""
    times = np.arange(0.0, sim_s, frame_s)
    chosen = select_frames(times, GifTiming())
    duration = sum(ms for _, ms in chosen) / 1000.0
    assert duration < 60.0
    span = recording_span(times)
    if span <= GifTiming().max_seconds:
        assert duration == pytest.approx(span, abs=0.1 + frame_s)  # short ones: real time
    else:
        assert duration == pytest.approx(GifTiming().max_seconds, abs=0.2)
    indices = [index for index, _ in chosen]
    assert indices == sorted(set(indices)) and indices[0] == 0
    slot_s = GifTiming().speed_for(span) * GifTiming().frame_ms() / 1000.0
    assert times[indices[-1]] >= times[-1] - slot_s  # the end is shown


def test_speed_and_fps_skip_frames_without_changing_the_recording() -> None:
    times = np.arange(0.0, 100.0, 0.05)  # 20 recorded frames per simulated second
    for fps, speed in ((10.0, 1.0), (10.0, 4.0), (5.0, 2.0), (25.0, 10.0)):
        chosen = select_frames(times, GifTiming(fps=fps, speed=speed))
        duration = sum(ms for _, ms in chosen) / 1000.0
        assert duration == pytest.approx(100.0 / speed, rel=0.02)
        # Each GIF frame shows the state ``speed / fps`` simulated seconds after the last.
        shown = times[[index for index, _ in chosen]]
        assert np.allclose(np.diff(shown), speed / fps, atol=0.05 + 1e-9)


def test_slow_recordings_hold_frames_instead_of_repeating_them() -> None:
    times = np.arange(0.0, 10.0, 0.5)  # 2 recorded frames per second, shown at 10 fps
    chosen = select_frames(times, GifTiming(fps=10.0, speed=1.0))
    assert [index for index, _ in chosen] == list(range(20))
    assert {ms for _, ms in chosen} == {500}


@pytest.mark.parametrize("bad", [{"fps": 0.0}, {"fps": 60.0}, {"speed": -1.0},
                                 {"max_seconds": 0.0}])
def test_bad_timings_are_refused(bad: dict[str, float]) -> None:
    with pytest.raises(ValueError):
        GifTiming(**bad)


def scene(shift: int) -> Image.Image:
    """A small real picture: a red square ``shift`` pixels from the left."""
    image = Image.new("RGB", (640, 480), (245, 245, 240))
    image.paste((200, 40, 40), (40 + shift, 100, 120 + shift, 180))
    return image


def test_captions_mark_the_bottom_band_and_differ_between_actions() -> None:
    band = caption_height(480, 640)
    first = np.asarray(caption(scene(0), "1/3  pick cup"), dtype=int)
    same = np.asarray(caption(scene(0), "1/3  pick cup"), dtype=int)
    other = np.asarray(caption(scene(0), "2/3  pour cup bowl"), dtype=int)
    plain = np.asarray(scene(0), dtype=int)
    assert np.array_equal(first, same)
    # The band is dark with light text; above it the picture is untouched.
    assert np.median(first[-band:]) < 60 < plain[-band:].mean()
    assert np.array_equal(first[:-band], plain[:-band])
    assert np.abs(first[-band:] - other[-band:]).sum() > 0
    assert np.array_equal(first[:-band], other[:-band])


def test_write_animation_keeps_size_captions_and_timing(tmp_path: Path) -> None:
    frames = [scene(k) for k in range(60)]
    times = [k * 0.1 for k in range(60)]
    captions = ["1/2  move"] * 30 + ["2/2  push block"] * 30
    info = write_animation(frames, times, captions, tmp_path / "a.gif",
                           GifTiming(fps=10.0, speed=2.0))
    n, duration, size = gif_timing(tmp_path / "a.gif")
    assert (n, size) == (info["frames"], (640, 480)) == (30, (640, 480))  # all differ
    assert duration == info["duration_s"] == pytest.approx(3.0)
    with Image.open(tmp_path / "a.gif") as gif:
        pictures = [np.asarray(f.convert("RGB"), dtype=int) for f in ImageSequence.Iterator(gif)]
    band = caption_height(480, 640)
    # Frames of one action share the caption band; frames of different actions do not.
    assert np.array_equal(pictures[0][-band:], pictures[14][-band:])
    assert not np.array_equal(pictures[14][-band:], pictures[15][-band:])
    still = write_animation(frames, times, captions, tmp_path / "last.png")
    assert still["frames"] == 1 and Image.open(tmp_path / "last.png").size == (640, 480)


def test_action_captions_and_focus() -> None:
    assert action_caption(3, 12, "pour", ["kettle", "@g4", "cup"]) == "3/12  pour kettle cup"
    kinds = {"cup": "cup", "bowl": "bowl", "spoon": "spoon", "kettle": "cup"}
    assert action_focus(["stirrer", "@g", "cup"], kinds) == "cup"
    assert action_focus(["Kettle", "bowl", "@q"], kinds) == "bowl"  # the last container
    assert action_focus(["spoon", "@g"], kinds) is None
