"""Pieces shared by the skill modules: scores' inputs and particle bookkeeping."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from Box2D import b2

from ltamp_cli.backends.box2d.geometry import Box
from ltamp_cli.backends.box2d.kitchenware import Pose
from ltamp_cli.backends.box2d.world import Kitchen, Observer


def new_kitchen(observer: Observer | None, *, furniture: bool = True, **kwargs: Any) -> Kitchen:
    """A fresh kitchen (see :mod:`..world` for why trials never share one)."""
    kitchen = Kitchen(furniture=furniture, **kwargs)
    if observer is not None:
        kitchen.observers.append(observer)
    return kitchen


def lowest_y(boxes: tuple[Box, ...], pose: Pose) -> float:
    """Lowest y of any corner of ``boxes`` placed at ``pose``."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    low = math.inf
    for box in boxes:
        for dx in (-box.hw, box.hw):
            for dy in (-box.hh, box.hh):
                x, y = box.cx + dx, box.cy + dy
                low = min(low, pose[1] + s * x + c * y)
    return low


def freeze(bodies: list[b2.body], mask: np.ndarray) -> int:
    """Turn the masked dynamic particles static (settled spill costs nothing to simulate)."""
    count = 0
    for body, flag in zip(bodies, mask, strict=True):
        if flag and body.type == b2.dynamicBody:
            body.type = b2.staticBody
            count += 1
    return count


def settled(kitchen: Kitchen, rest_speed: float) -> bool:
    speeds = kitchen.particle_speeds()
    return bool(np.all(speeds < rest_speed))
