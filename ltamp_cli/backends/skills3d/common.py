"""Pieces shared by the Kitchen3D skills: latent physical properties, the geometric
pre-check of a tool path against a bowl, and the start of a trial (:class:`SkillTrial`:
parsed context and control, tool path, pre-check verdict) before any engine is touched."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Generic, TypeVar

import numpy as np

from ltamp_cli.backends.kitchenware_geometry import (
    KitchenwareGeometry,
    VesselDims,
    check_points,
    points_in_vessel_wall,
)
from ltamp_cli.backends.protocol import SkillSpec, TrialResult
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial
from ltamp_cli.backends.pybullet.particles import BeadSpec
from ltamp_cli.backends.pybullet.paths import PosePath

SceneT = TypeVar("SceneT")

#: Point spacing (m) on the tool surface for the collision pre-check.
CHECK_SPACING_M = 0.004


def truncated_normal(
    rng: np.random.Generator, mean: float, std: float, low: float, high: float
) -> float:
    """One draw of ``N(mean, std²)`` restricted to ``[low, high]`` (by rejection)."""
    for _ in range(1000):
        value = rng.normal(mean, std)
        if low <= value <= high:
            return float(value)
    return float(np.clip(mean, low, high))


def sample_beads(rng: np.random.Generator, count_mean: float, count_std: float,
                 count_low: float, count_high: float) -> BeadSpec:
    """Bead size, mass, count and surface properties for one trial (field facts: radius
    ~6 mm, friction ~N(0.5, 0.1), restitution ~N(0.7, 0.1))."""
    radius = truncated_normal(rng, 0.006, 0.0005, 0.005, 0.007)
    density = truncated_normal(rng, 1000.0, 150.0, 700.0, 1300.0)
    count = round(truncated_normal(rng, count_mean, count_std, count_low, count_high))
    return BeadSpec(
        count=count,
        radius=radius,
        mass=density * 4.0 / 3.0 * math.pi * radius**3,
        lateral_friction=truncated_normal(rng, 0.5, 0.1, 0.2, 0.8),
        restitution=truncated_normal(rng, 0.7, 0.1, 0.4, 0.9),
    )


def sample_material(rng: np.random.Generator, rgba: tuple[float, float, float, float],
                    mass: tuple[float, float, float, float] | None = None) -> BodyMaterial:
    """Friction and restitution of a kitchenware body; ``mass`` = (mean, std, low, high) in
    kg, or ``None`` for a fixed body. Draw order: mass, friction, restitution."""
    return BodyMaterial(
        mass=0.0 if mass is None else truncated_normal(rng, *mass),
        lateral_friction=truncated_normal(rng, 0.5, 0.1, 0.2, 0.8),
        restitution=truncated_normal(rng, 0.1, 0.05, 0.0, 0.2),
        rgba=rgba,
    )


BOWL_RGBA = (0.85, 0.85, 0.8, 1.0)


def batch_path_validity(tool: KitchenwareGeometry, paths: Iterable[PosePath],
                        bowl: VesselDims) -> np.ndarray:
    """The pre-check for a batch of tool paths: bool ``(n,)``."""
    points = check_points(tool, CHECK_SPACING_M)
    return np.array([check_tool_path(tool, path, bowl, tool_points=points).valid
                     for path in paths], dtype=bool)


@dataclass(frozen=True)
class PathCheck:
    """Outcome of the pre-check: ``valid`` and the index of the first colliding pose."""

    valid: bool
    first_hit: int = -1
    reason: str = ""


def rejection(spec: SkillSpec, verdict: PathCheck) -> TrialResult | None:
    """The result of a trial whose pre-check failed (the skill's invalid score, not valid,
    the reason in ``info``), or ``None`` when it passed."""
    if verdict.valid:
        return None
    return TrialResult(spec.invalid_score, False, {"reason": verdict.reason})


@dataclass(frozen=True)
class SkillTrial(Generic[SceneT]):
    """The engine-independent start of one trial, before any world is touched.

    ``scene``: the parsed context (e.g. a ``PourContext``); ``control``: the flattened
    control ``(d_control,)``; ``path``: the tool's poses in the scene frame; ``tool``: the
    tool's geometry; ``rejected``: the result to return without simulating when the
    pre-check ran and failed, else ``None``.
    """

    scene: SceneT
    control: np.ndarray
    path: PosePath
    tool: KitchenwareGeometry
    rejected: TrialResult | None


def check_tool_path(
    tool: KitchenwareGeometry,
    path: PosePath,
    bowl: VesselDims,
    spacing: float = CHECK_SPACING_M,
    tool_points: tuple[np.ndarray, float] | None = None,
) -> PathCheck:
    """Does ``tool`` moved along ``path`` stay clear of ``bowl`` (at the origin) and the table?

    Conservative: points of the tool (:func:`check_points`, about ``spacing`` apart), on
    poses resampled so no point moves more than ``spacing`` between them, must stay
    ``spacing`` (plus the points' own margin) away from the bowl's material and above the
    table. ``tool_points`` caches ``check_points(tool, spacing)`` across a batch.
    """
    points, own_margin = check_points(tool, spacing) if tool_points is None else tool_points
    dense = path.densify(points, max_move=spacing)
    chunk = max(1, 200_000 // max(len(points), 1))
    for start in range(0, len(dense), chunk):
        part = PosePath(
            dense.positions[start : start + chunk], dense.quaternions[start : start + chunk]
        )
        world = part.transform(points)  # (k, m, 3)
        below = (world[..., 2] < own_margin).any(axis=1)
        hits = points_in_vessel_wall(world.reshape(-1, 3), bowl, margin=spacing + own_margin)
        hits = hits.reshape(world.shape[:2]).any(axis=1)
        bad = np.flatnonzero(below | hits)
        if bad.size:
            index = int(bad[0])
            reason = "tool path hits the bowl" if hits[index] else "tool path goes below the table"
            return PathCheck(False, start + index, reason)
    return PathCheck(True)
