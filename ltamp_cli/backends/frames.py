"""Animations a researcher can show: captioned frames, insets and GIF timing.

Every backend records frames at a fixed simulated rate together with the simulated time
and the plan action running at that instant. :func:`write_animation` then *subsamples*
the recording (the physics is never sped up) so that one GIF second shows
:attr:`GifTiming.speed` simulated seconds, captions every kept frame with its action and
writes the GIF (another suffix: the last frame as a still image).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ltamp_cli.atomic_file import replaced_atomically

#: What :func:`write_animation` wrote (path, frames, duration_s, speed, width, height).
AnimationInfo = dict[str, float | int | str]

#: GIF frame delays are whole centiseconds and viewers slow down delays under 20 ms.
MIN_FRAME_MS = 20


@dataclass(frozen=True)
class GifTiming:
    """How recorded time maps to GIF time.

    ``fps``: GIF frames per second (at most 50). ``speed``: simulated seconds shown per GIF
    second; ``None`` picks real time (1×) unless that would make the GIF longer than
    ``max_seconds``, then just fast enough to last ``max_seconds``.
    """

    fps: float = 10.0
    speed: float | None = None
    max_seconds: float = 45.0

    def __post_init__(self) -> None:
        if not (0 < self.fps <= 1000.0 / MIN_FRAME_MS):
            raise ValueError(f"fps must be in (0, {1000 // MIN_FRAME_MS}], got {self.fps:g}")
        if self.speed is not None and not self.speed > 0:
            raise ValueError(f"speed must be positive, got {self.speed:g}")
        if not self.max_seconds > 0:
            raise ValueError(f"max_seconds must be positive, got {self.max_seconds:g}")

    def frame_ms(self) -> int:
        """The delay of one GIF frame in milliseconds (a multiple of 10, ≥ 20)."""
        return max(MIN_FRAME_MS, 10 * round(100.0 / self.fps))

    def speed_for(self, sim_seconds: float) -> float:
        """Simulated seconds per GIF second for a recording spanning ``sim_seconds``."""
        if self.speed is not None:
            return self.speed
        return max(1.0, sim_seconds / self.max_seconds)


def recording_span(times_s: Sequence[float]) -> float:
    """Simulated seconds a recording covers: first to last frame plus one recording step
    (the last frame lasts as long as the others)."""
    times = np.asarray(times_s, dtype=float)
    if times.size < 2:
        return 0.0
    return float(times[-1] - times[0] + np.median(np.diff(times)))


def select_frames(times_s: Sequence[float], timing: GifTiming) -> list[tuple[int, int]]:
    """Which recorded frames to show and for how long.

    ``times_s`` ``(n,)``: simulated time of each recorded frame, non-decreasing. Returns
    ``(index, duration_ms)`` pairs in order: GIF slot ``k`` shows the last frame recorded
    at or before ``k · frame_ms · speed`` simulated ms after the first; consecutive slots
    showing the same frame are merged into one longer frame.
    """
    times = np.asarray(times_s, dtype=float)
    if times.size == 0:
        return []
    if np.any(np.diff(times) < 0):
        raise ValueError("frame times must be non-decreasing")
    span = recording_span(times)
    frame_ms = timing.frame_ms()
    slot_s = frame_ms / 1000.0 * timing.speed_for(span)
    n_slots = max(1, math.ceil(span / slot_s - 1e-9))
    slot_times = times[0] + slot_s * np.arange(n_slots)
    indices = np.searchsorted(times, slot_times + 1e-9, side="right") - 1
    chosen: list[tuple[int, int]] = []
    for index in np.clip(indices, 0, times.size - 1).tolist():
        if chosen and chosen[-1][0] == index:
            chosen[-1] = (index, chosen[-1][1] + frame_ms)
        else:
            chosen.append((index, frame_ms))
    return chosen


def action_caption(number: int, total: int, name: str, args: Sequence[str]) -> str:
    """The caption of plan step ``number`` of ``total``: ``"3/12  pour kettle g0 cup"``
    (values the planner made up, named ``@...``, are left out)."""
    named = [str(a) for a in args if not str(a).startswith("@")]
    return f"{number}/{total}  {' '.join([name, *named])}"


def action_focus(args: Sequence[str], kinds: Mapping[str, str],
                 containers: Sequence[str] = ("cup", "bowl")) -> str | None:
    """The container an action works on: its last argument naming an object whose kind
    (``kinds``: object name -> kind) is one of ``containers``; ``None`` if there is none."""
    for name in reversed([str(a).lower() for a in args]):
        if kinds.get(name) in containers:
            return name
    return None


def _font(height_px: int) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    return ImageFont.load_default(size=height_px)


def _caption_font_px(height: int, width: int) -> int:
    # Readable on wide, flat pictures too (the 2D kitchen is 960 × 288), never huge.
    return max(11, min(height // 12, max(height // 24, width // 64)))


def caption_height(height: int, width: int = 0) -> int:
    """Pixels the caption band of :func:`caption` covers at the bottom of an image
    ``width`` × ``height`` pixels."""
    size = _caption_font_px(height, width)
    return size + 2 * max(3, size // 3)


def caption(image: Image.Image, text: str) -> Image.Image:
    """A copy of ``image`` with ``text`` in a dark band along its bottom edge (same size).

    The text size follows the image size (see :func:`caption_height`); text too long for
    one line is cut with an ellipsis.
    """
    out = image.convert("RGB")
    if not text:
        return out
    width, height = out.size
    size = _caption_font_px(height, width)
    font = _font(size)
    pen = ImageDraw.Draw(out)
    pad = max(3, size // 3)
    band = caption_height(height, width)
    pen.rectangle([0, height - band, width, height], fill=(25, 25, 35))
    shown = text
    while shown and pen.textlength(shown, font=font) > width - 2 * pad:
        shown = shown[:-2] + "…"
    pen.text((pad, height - band + pad), shown, fill=(255, 255, 255), font=font)
    return out


def inset(image: Image.Image, small: Image.Image, label: str = "") -> Image.Image:
    """A copy of ``image`` with ``small`` pasted in its top-right corner, framed, with an
    optional ``label`` above it."""
    out = image.convert("RGB")
    margin = max(4, out.size[1] // 60)
    x = out.size[0] - small.size[0] - margin
    y = margin
    pen = ImageDraw.Draw(out)
    pen.rectangle([x - 2, y - 2, x + small.size[0] + 1, y + small.size[1] + 1],
                  outline=(255, 255, 255), width=2)
    out.paste(small.convert("RGB"), (x, y))
    if label:
        size = max(10, small.size[1] // 12)
        font = _font(size)
        pen.rectangle([x, y, x + pen.textlength(label, font=font) + 6, y + size + 4],
                      fill=(20, 20, 30))
        pen.text((x + 3, y + 1), label, fill=(255, 255, 255), font=font)
    return out


def as_image(frame: Image.Image | np.ndarray) -> Image.Image:
    """A PIL RGB image of ``frame`` (a PIL image or an ``(h, w, 3)`` uint8 array)."""
    if isinstance(frame, Image.Image):
        return frame.convert("RGB")
    return Image.fromarray(np.asarray(frame, dtype=np.uint8)[..., :3])


def write_animation(
    frames: Sequence[Image.Image | np.ndarray],
    times_s: Sequence[float],
    captions: Sequence[str],
    path: str | Path,
    timing: GifTiming | None = None,
    colours: int = 128,
) -> AnimationInfo:
    """Write ``frames`` (recorded at ``times_s``, showing ``captions``) to ``path``.

    ``.gif``: the frames :func:`select_frames` keeps, each captioned and reduced to a
    ``colours``-colour palette; another suffix: the last frame, captioned. Returns what was
    written: ``path``, ``frames`` (GIF frames), ``duration_s`` (GIF playing time),
    ``speed`` (simulated seconds per GIF second), ``width`` and ``height`` in pixels and
    ``write_s``, the seconds it took (drawing lazily rendered frames included).
    """
    if not frames:
        raise ValueError("no frames to save")
    if not (len(frames) == len(times_s) == len(captions)):
        raise ValueError(f"{len(frames)} frames but {len(times_s)} times and "
                         f"{len(captions)} captions")
    timing = timing or GifTiming()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() != ".gif":
        last = caption(as_image(frames[-1]), captions[-1])
        with replaced_atomically(path) as temporary:
            last.save(temporary)
        return {"path": str(path), "frames": 1, "duration_s": 0.0, "speed": 0.0,
                "width": last.size[0], "height": last.size[1]}
    started = time.perf_counter()
    chosen = select_frames(times_s, timing)
    # Few flat colours: a fast octree palette per frame without dithering looks the same
    # and saves several times faster than Pillow's default median cut.
    images = [caption(as_image(frames[index]), captions[index]).quantize(
        colors=colours, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
        for index, _ in chosen]
    durations = [ms for _, ms in chosen]
    with replaced_atomically(path) as temporary:  # never seen half-written
        images[0].save(temporary, save_all=True, append_images=images[1:],
                       duration=durations, loop=0, optimize=False)
    span = recording_span(times_s)
    return {"path": str(path), "frames": len(images), "duration_s": sum(durations) / 1000.0,
            "speed": round(timing.speed_for(span), 3), "width": images[0].size[0],
            "height": images[0].size[1], "write_s": round(time.perf_counter() - started, 2)}


__all__ = [
    "AnimationInfo",
    "GifTiming",
    "action_caption",
    "action_focus",
    "as_image",
    "caption",
    "caption_height",
    "inset",
    "recording_span",
    "select_frames",
    "write_animation",
]
