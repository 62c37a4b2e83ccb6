"""Joint-space interpolation, dense path re-checking and shortcutting.

All paths are arrays of shape ``(n_waypoints, dof)``; ``resolution`` is the largest allowed
per-joint change (infinity norm, in joint units: radians for revolute joints) between two
consecutive checked configurations.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np

ValidityFn = Callable[[np.ndarray], bool]


def _as_path(path: np.ndarray) -> np.ndarray:
    array = np.asarray(path, dtype=float)
    if array.ndim != 2 or array.shape[0] == 0:
        raise ValueError(f"a path must have shape (n_waypoints, dof), n >= 1; got {array.shape}")
    return array


def interpolate_configurations(
    q_from: np.ndarray, q_to: np.ndarray, resolution: float
) -> np.ndarray:
    """Straight joint-space segment from ``q_from`` to ``q_to``, both included.

    Returns shape ``(n, dof)`` with ``n >= 2`` and every step's infinity norm ``<= resolution``.
    """
    if resolution <= 0:
        raise ValueError("resolution must be positive")
    start = np.asarray(q_from, dtype=float)
    end = np.asarray(q_to, dtype=float)
    if start.shape != end.shape or start.ndim != 1:
        raise ValueError(f"configurations must be 1-D of equal shape: {start.shape}, {end.shape}")
    largest_step = float(np.max(np.abs(end - start))) if start.size else 0.0
    n_steps = max(1, int(np.ceil(largest_step / resolution)))
    fractions = np.linspace(0.0, 1.0, n_steps + 1)[:, None]
    return start[None, :] + fractions * (end - start)[None, :]


def densify_path(path: np.ndarray, resolution: float) -> np.ndarray:
    """Insert configurations so no step of ``path`` exceeds ``resolution``; shape ``(m, dof)``."""
    waypoints = _as_path(path)
    if waypoints.shape[0] == 1:
        return waypoints.copy()
    pieces = [waypoints[:1]]
    for q_from, q_to in itertools.pairwise(waypoints):
        pieces.append(interpolate_configurations(q_from, q_to, resolution)[1:])
    return np.concatenate(pieces, axis=0)


def path_length(path: np.ndarray) -> float:
    """Sum of Euclidean joint-space segment lengths of ``path`` (joint units)."""
    waypoints = _as_path(path)
    return float(np.sum(np.linalg.norm(np.diff(waypoints, axis=0), axis=1)))


def first_invalid_configuration(
    path: np.ndarray, is_valid: ValidityFn, resolution: float
) -> int | None:
    """Index into ``densify_path(path, resolution)`` of the first invalid configuration.

    ``None`` when every densely interpolated configuration passes ``is_valid``.
    """
    for index, q in enumerate(densify_path(path, resolution)):
        if not is_valid(q):
            return index
    return None


def is_path_valid(path: np.ndarray, is_valid: ValidityFn, resolution: float) -> bool:
    """True when every configuration of the densified path is valid."""
    return first_invalid_configuration(path, is_valid, resolution) is None


def _segment_valid(
    q_from: np.ndarray, q_to: np.ndarray, is_valid: ValidityFn, resolution: float
) -> bool:
    # Endpoints are already known to be valid: check only the interior.
    interior = interpolate_configurations(q_from, q_to, resolution)[1:-1]
    # Bisection order finds collisions in the middle of a segment early.
    order = _bisection_order(interior.shape[0])
    return all(is_valid(interior[i]) for i in order)


def _bisection_order(n: int) -> list[int]:
    order: list[int] = []
    queue = [(0, n)]
    while queue:
        low, high = queue.pop(0)
        if low >= high:
            continue
        middle = (low + high) // 2
        order.append(middle)
        queue.append((low, middle))
        queue.append((middle + 1, high))
    return order


def shortcut_path(
    path: np.ndarray,
    is_valid: ValidityFn,
    resolution: float,
    rng: np.random.Generator,
    iterations: int = 100,
) -> np.ndarray:
    """Random shortcutting: replace sub-paths by straight segments that are valid.

    Picks two random points on the (piecewise-linear) path and, when the straight segment
    between them is valid at ``resolution``, splices it in. The endpoints never change and
    the result is never longer than ``path``. Returns shape ``(k, dof)``.
    """
    waypoints = _as_path(path).copy()
    for _ in range(iterations):
        if waypoints.shape[0] < 3:
            break
        segment_lengths = np.linalg.norm(np.diff(waypoints, axis=0), axis=1)
        cumulative = np.concatenate([[0.0], np.cumsum(segment_lengths)])
        total = cumulative[-1]
        if total <= 0:
            break
        s_a, s_b = np.sort(rng.uniform(0.0, total, size=2))
        i_a = int(np.searchsorted(cumulative, s_a, side="right") - 1)
        i_b = int(np.searchsorted(cumulative, s_b, side="right") - 1)
        i_a = min(i_a, waypoints.shape[0] - 2)
        i_b = min(i_b, waypoints.shape[0] - 2)
        if i_a == i_b:
            continue
        q_a = _point_on_segment(waypoints, cumulative, segment_lengths, i_a, s_a)
        q_b = _point_on_segment(waypoints, cumulative, segment_lengths, i_b, s_b)
        if not (is_valid(q_a) and is_valid(q_b)):
            continue
        if not _segment_valid(q_a, q_b, is_valid, resolution):
            continue
        waypoints = np.concatenate(
            [waypoints[: i_a + 1], q_a[None], q_b[None], waypoints[i_b + 1 :]], axis=0
        )
        waypoints = _drop_duplicates(waypoints)
    return waypoints


def _point_on_segment(
    waypoints: np.ndarray,
    cumulative: np.ndarray,
    segment_lengths: np.ndarray,
    index: int,
    arc: float,
) -> np.ndarray:
    length = segment_lengths[index]
    fraction = 0.0 if length <= 0 else (arc - cumulative[index]) / length
    return waypoints[index] + float(np.clip(fraction, 0.0, 1.0)) * (
        waypoints[index + 1] - waypoints[index]
    )


def _drop_duplicates(waypoints: np.ndarray, tolerance: float = 1e-12) -> np.ndarray:
    keep = [0]
    for index in range(1, waypoints.shape[0]):
        if np.max(np.abs(waypoints[index] - waypoints[keep[-1]])) > tolerance:
            keep.append(index)
    if keep[-1] != waypoints.shape[0] - 1:
        keep[-1] = waypoints.shape[0] - 1
    return waypoints[keep]
