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


def rotated_hits(centers: np.ndarray, angles: np.ndarray, half: np.ndarray,
                 fixed: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """Whether rotated rectangles overlap axis-aligned boxes (exact separating-axis test).

    ``centers``: world centres ``(..., 2)``; ``angles``: rotations ``(...)`` (rad);
    ``half``: half extents ``(..., 2)`` along the rectangle's own axes; the three broadcast
    together. ``fixed``: ``(k, 4)`` boxes as ``(xmin, ymin, xmax, ymax)``, grown by
    ``margin``. Returns ``(...)``: does the rectangle overlap any fixed box (touching is not
    overlapping)?

    Works on centres and extents only (projected radii), not on corner arrays, so a batch of
    thousands of controls × tens of tilt angles stays a few flat array passes.
    """
    f_center = (fixed[:, :2] + fixed[:, 2:]) / 2.0  # (k, 2)
    f_half = (fixed[:, 2:] - fixed[:, :2]) / 2.0 + margin  # (k, 2)
    c = np.abs(np.cos(angles))[..., None]
    s = np.abs(np.sin(angles))[..., None]
    cos_, sin_ = np.cos(angles)[..., None], np.sin(angles)[..., None]
    hw, hh = half[..., 0:1], half[..., 1:2]  # (..., 1)
    dx = centers[..., 0:1] - f_center[:, 0]  # (..., k)
    dy = centers[..., 1:2] - f_center[:, 1]
    fx, fy = f_half[:, 0], f_half[:, 1]
    separated = np.abs(dx) >= hw * c + hh * s + fx
    separated |= np.abs(dy) >= hw * s + hh * c + fy
    separated |= np.abs(dx * cos_ + dy * sin_) >= hw + fx * c + fy * s
    separated |= np.abs(dy * cos_ - dx * sin_) >= hh + fx * s + fy * c
    return ~separated.all(axis=-1)
