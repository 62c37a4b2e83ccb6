"""Saving rendered frames: an animated GIF, or the last frame as a still image."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np


def save_frames(frames: Sequence[np.ndarray], path: Path, fps: float = 12.0) -> Path:
    """Write ``frames`` (each ``(h, w, 3)`` uint8) to ``path``: ``.gif`` animates them,
    another suffix (``.png``) keeps the last frame. Returns ``path``."""
    from PIL import Image

    if not frames:
        raise ValueError("no frames to save")
    path.parent.mkdir(parents=True, exist_ok=True)
    images = [Image.fromarray(np.asarray(frame, dtype=np.uint8)) for frame in frames]
    if path.suffix.lower() == ".gif":
        images[0].save(path, save_all=True, append_images=images[1:],
                       duration=round(1000.0 / fps), loop=0)
    else:
        images[-1].save(path)
    return path
