"""Axis-aligned boxes: the shapes of every Kitchen2D part and the cheap overlap tests.

Validity checks never simulate: at a skill's start every part is upright, so parts are
axis-aligned boxes and overlap is an interval test, vectorised over a batch of controls.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Box:
    """A box in a body's frame: centre ``(cx, cy)`` and half extents ``(hw, hh)``."""

    cx: float
    cy: float
    hw: float
    hh: float


def aabbs(boxes: tuple[Box, ...], x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """World AABBs of upright ``boxes`` placed at origins ``(x, y)`` (shape ``(n,)`` each).

    Returns shape ``(n, len(boxes), 4)`` as ``(xmin, ymin, xmax, ymax)``.
    """
    local = np.array([[b.cx - b.hw, b.cy - b.hh, b.cx + b.hw, b.cy + b.hh] for b in boxes])
    shift = np.stack([x, y, x, y], axis=-1)[:, None, :]
    return local[None, :, :] + shift


def sweep(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """AABBs covering boxes translated (without rotation) from ``a`` to ``b`` (same shapes)."""
    return np.concatenate(
        [np.minimum(a[..., :2], b[..., :2]), np.maximum(a[..., 2:], b[..., 2:])], -1
    )


def any_overlap(a: np.ndarray, b: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """Whether any box of ``a`` (``(n, p, 4)``) overlaps any of ``b`` (``(n, q, 4)``).

    Boxes closer than ``margin`` count as overlapping; returns shape ``(n,)``.
    """
    a4 = a[:, :, None, :]
    b4 = b[:, None, :, :]
    sep = (
        (a4[..., 2] + margin <= b4[..., 0])
        | (b4[..., 2] + margin <= a4[..., 0])
        | (a4[..., 3] + margin <= b4[..., 1])
        | (b4[..., 3] + margin <= a4[..., 1])
    )
    return ~np.all(sep, axis=(1, 2))
