"""Draw Kitchen2D worlds with Pillow, record trial frames and save PNG/GIF files.

Recordings keep the simulated time and a caption (the running action) with every frame;
:func:`~ltamp_cli.backends.frames.write_animation` subsamples and captions them. A
recorder can *follow* what moves: the image keeps its pixel size while the window pans
(and zooms out when needed) to keep every moving body and the goal in view.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from Box2D import b2
from PIL import Image, ImageDraw, ImageFont

from ltamp_cli.backends.box2d.world import Kitchen
from ltamp_cli.backends.frames import AnimationInfo, GifTiming, caption_height, write_animation

Bounds = tuple[float, float, float, float]


@dataclass(frozen=True)
class View:
    """World window ``(xmin, ymin, xmax, ymax)`` drawn at ``scale`` pixels per unit."""

    bounds: Bounds
    scale: float = 40.0


@dataclass(frozen=True)
class Region:
    """A goal area ``bounds`` (world units, kept in view) drawn as a tinted box labelled
    ``label``; with ``below`` everything under its top edge is tinted, across the image."""

    bounds: Bounds
    label: str
    below: bool = False


#: Static bodies that mark something to show (a push goal): always framed, drawn as a ring.
MARKERS = frozenset({"goal"})
#: How far (world units) above a goal box its label floats: above what stands in the box.
LABEL_RISE = 7.0
#: Smallest radius (world units) a marker is drawn with, so a point goal stays visible.
MARKER_RADIUS = 0.5


#: Smallest image (width, height) in pixels a following recorder draws.
FOLLOW_MIN_PX = (640, 480)


def auto_bounds(kitchen: Kitchen, margin: float = 2.0) -> Bounds:
    """A window around every non-static body, static particles and goal markers."""
    xs: list[float] = []
    ys: list[float] = []
    for body in kitchen.world.bodies:
        name = (body.userData or {}).get("name")
        if body.type == b2.staticBody and name != "particle" and name not in MARKERS:
            continue
        if name in MARKERS:
            x, y = body.position
            xs += [x - MARKER_RADIUS, x + MARKER_RADIUS]
            ys += [y - MARKER_RADIUS, y + MARKER_RADIUS]
        for fixture in body.fixtures:
            box = fixture.GetAABB(0)
            xs += [box.lowerBound[0], box.upperBound[0]]
            ys += [box.lowerBound[1], box.upperBound[1]]
    if not xs:
        lay = kitchen.layout
        return (-lay.width / 2, 0.0, lay.width / 2, lay.height)
    return (min(xs) - margin, min(ys) - margin, max(xs) + margin, max(ys) + margin)


def union(a: Bounds, b: Bounds) -> Bounds:
    """The smallest window holding both ``a`` and ``b``."""
    return (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))


def follow_view(content: Bounds, size_px: tuple[int, int], max_scale: float,
                reserve_px: int = 0) -> View:
    """A window of ``size_px`` (width, height) pixels showing all of ``content``, centred
    on it above a bottom strip of ``reserve_px`` pixels (where the caption goes):
    ``max_scale`` pixels per unit, or fewer when ``content`` would not fit."""
    width, height = size_px
    usable = max(1, height - reserve_px)
    cw, ch = max(content[2] - content[0], 1e-6), max(content[3] - content[1], 1e-6)
    scale = min(max_scale, width / cw, usable / ch)
    cx, cy = (content[0] + content[2]) / 2, (content[1] + content[3]) / 2
    half_w, half_h = width / scale / 2, usable / scale / 2
    return View((cx - half_w, cy - half_h - reserve_px / scale, cx + half_w, cy + half_h), scale)


def draw(kitchen: Kitchen, view: View, regions: Sequence[Region] = ()) -> Image.Image:
    """One RGB frame of the kitchen as seen through ``view``, goal ``regions`` tinted."""
    x0, y0, x1, y1 = view.bounds
    s = view.scale
    width, height = max(1, round((x1 - x0) * s)), max(1, round((y1 - y0) * s))
    image = Image.new("RGB", (width, height), (250, 250, 245))
    pen = ImageDraw.Draw(image)

    def px(x: float, y: float) -> tuple[float, float]:
        return ((x - x0) * s, (y1 - y) * s)

    font = ImageFont.load_default(size=max(11, height // 30))
    for region in regions:
        a, b = px(region.bounds[0], region.bounds[3]), px(region.bounds[2], region.bounds[1])
        if region.below:
            a, b = (0.0, a[1]), (float(width), float(height))
        pen.rectangle([a, b], fill=(215, 240, 215), outline=(40, 150, 60), width=2)
        if region.below:  # a band's label sits inside it
            pen.text((4, max(a[1], 0) + 3), region.label, fill=(30, 110, 45), font=font)
            continue
        # A box's label floats above what will stand in it, with a line down to the box.
        middle = (a[0] + b[0]) / 2
        top = a[1] - LABEL_RISE * s
        pen.line([(middle, top + font.size + 2), (middle, a[1])], fill=(40, 150, 60), width=1)
        pen.text((max(middle - 10, 0), max(top, 0)), region.label, fill=(30, 110, 45),
                 font=font)
    for body in kitchen.world.bodies:
        data = body.userData or {}
        color = tuple(data.get("color", (128, 128, 128)))
        if data.get("name") in MARKERS:
            cx, cy = px(*body.position)
            r = MARKER_RADIUS * s
            pen.ellipse([cx - r, cy - r, cx + r, cy + r], outline=color, width=3)
            pen.line([cx - r, cy, cx + r, cy], fill=color, width=2)
            pen.line([cx, cy - r, cx, cy + r], fill=color, width=2)
            pen.text((cx + r + 3, cy - r), str(data["name"]), fill=color, font=font)
            continue
        for fixture in body.fixtures:
            shape = fixture.shape
            if isinstance(shape, b2.circleShape):
                cx, cy = px(*body.GetWorldPoint(shape.pos))
                r = max(1.0, shape.radius * s)
                pen.ellipse([cx - r, cy - r, cx + r, cy + r], fill=color)
            elif isinstance(shape, b2.polygonShape):
                points = [px(*body.GetWorldPoint(v)) for v in shape.vertices]
                pen.polygon(points, fill=color, outline=(30, 30, 30))
    return image


class FrameRecorder:
    """Observer that keeps a frame every ``every`` physics steps.

    ``view`` fixes the window (default: :func:`auto_bounds` at the first frame). With
    ``follow`` the image keeps the first window's pixel size but each frame re-centres on
    what moves (and the goal ``regions``), zooming out when it would not fit. Set
    :attr:`caption` to the running action: it is kept with every frame, as is the time.
    """

    def __init__(self, every: int = 5, view: View | None = None, scale: float = 40.0,
                 *, follow: bool = False, regions: Sequence[Region] = ()) -> None:
        if every < 1:
            raise ValueError("every must be at least 1")
        self.every = every
        self.view = view
        self.scale = scale
        self.follow = follow
        self.regions = tuple(regions)
        self.caption = ""
        self.frames: list[Image.Image] = []
        self.times: list[float] = []
        self.captions: list[str] = []

    def __call__(self, kitchen: Kitchen) -> None:
        if kitchen.steps % self.every:
            return
        if self.view is None:
            self.view = View(auto_bounds(kitchen, margin=3.0), self.scale)
        view = self.view
        if self.follow:
            content = auto_bounds(kitchen, margin=1.5)
            for region in self.regions:
                content = union(content, region.bounds)
            x0, y0, x1, y1 = self.view.bounds
            size = (max(FOLLOW_MIN_PX[0], round((x1 - x0) * self.view.scale)),
                    max(FOLLOW_MIN_PX[1], round((y1 - y0) * self.view.scale)))
            view = follow_view(content, size, self.view.scale, caption_height(size[1], size[0]))
        self.frames.append(draw(kitchen, view, self.regions))
        self.times.append(kitchen.time)
        self.captions.append(self.caption)

    def save(self, path: str | Path, timing: GifTiming | None = None) -> AnimationInfo:
        """Write the recording (see :func:`~ltamp_cli.backends.frames.write_animation`)."""
        return write_animation(self.frames, self.times, self.captions, path, timing, colours=64)


def save_frames(frames: Sequence[Image.Image], path: str | Path, fps: float = 20.0) -> Path:
    """Save uncaptioned frames recorded ``fps`` per simulated second as a real-time GIF
    (``.gif``) or the last frame as a PNG (otherwise)."""
    write_animation(frames, [i / fps for i in range(len(frames))], [""] * len(frames), path,
                    GifTiming(fps=min(fps, 50.0), speed=1.0), colours=64)
    return Path(path)
