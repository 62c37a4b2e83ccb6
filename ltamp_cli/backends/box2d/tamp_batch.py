"""Vectorised forms of the kitchen's skill-setup tests, for learned streams' samplers.

:meth:`~ltamp_cli.backends.box2d.tamp.KitchenGeometry.pour_setup`, ``scoop_setup`` and
``push_setup`` test one control at a time (approach and swing clear of the furniture and the
other spots, the tilting cup not grazing the target's walls, ...). A learned stream's sampler
needs the same verdict for whole candidate batches, *inside* its super-level set (otherwise
the set's θ*, β and proposals are built around controls the kitchen then throws away: only
0–3 % of the generic samplers' pours survived the kitchen's tests that way). The functions
here return ``(n,)`` bools for controls ``(n, dθ)`` and agree with the per-control tests
(``tests/kitchen2d/test_learned_pour_scoop.py`` checks it): same geometry, same rounding to
1e-4 of grasps and starts, the same 24 tilt angles.

Rects are ``(xmin, ymin, xmax, ymax)`` in world units; a hand's boxes are given relative to
the gripper origin.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ltamp_cli.backends.box2d.geometry import Box
from ltamp_cli.backends.box2d.scene import SceneObject
from ltamp_cli.backends.box2d.skills import pour as pour_skill
from ltamp_cli.backends.box2d.skills import scoop as scoop_skill
from ltamp_cli.backends.box2d.tamp import (
    MIN_GRIP,
    PUSH_SPEED,
    TRANSIT_MARGIN,
    KitchenGeometry,
    Point,
)

#: Candidates per chunk of the tilt tests (bounds the (n, angles, points, walls) arrays).
CHUNK = 128
#: Tilt angles checked per pour (as :meth:`KitchenGeometry.pour_setup`).
N_ANGLES = 24
#: Margin of the axis-aligned overlap test (as :meth:`KitchenGeometry.overlaps`).
MARGIN = 0.02


def _round(values: np.ndarray) -> np.ndarray:
    return np.round(np.asarray(values, dtype=float), 4)


def _rel_rects(boxes: Sequence[Box]) -> np.ndarray:
    """Upright boxes relative to their body's origin, ``(m, 4)``."""
    return np.array([[b.cx - b.hw, b.cy - b.hh, b.cx + b.hw, b.cy + b.hh] for b in boxes],
                    dtype=float).reshape(-1, 4)


def _corners(boxes: Sequence[Box]) -> np.ndarray:
    """Corners of boxes in their body's frame, ``(4m, 2)``."""
    return np.array([(b.cx + dx, b.cy + dy) for b in boxes for dx in (-b.hw, b.hw)
                     for dy in (-b.hh, b.hh)], dtype=float).reshape(-1, 2)


def _edge_points(boxes: Sequence[Box], per_edge: int = 12) -> np.ndarray:
    """Points along every edge of the boxes, ``(16·per_edge·m/4, 2)``, in the body's frame
    (as :meth:`KitchenGeometry.hand_edge_points`)."""
    t = np.linspace(0.0, 1.0, per_edge)
    out = []
    for b in boxes:
        corners = np.array([[b.cx - b.hw, b.cy - b.hh], [b.cx + b.hw, b.cy - b.hh],
                            [b.cx + b.hw, b.cy + b.hh], [b.cx - b.hw, b.cy + b.hh]])
        for k in range(4):
            a, z = corners[k], corners[(k + 1) % 4]
            out.append(a[None, :] + t[:, None] * (z - a)[None, :])
    return np.concatenate(out) if out else np.zeros((0, 2))


def hits(rects: np.ndarray, obstacles: np.ndarray, margin: float = MARGIN) -> np.ndarray:
    """Whether any of each candidate's rects ``(n, m, 4)`` overlaps an obstacle ``(k, 4)``:
    ``(n,)`` bools."""
    if len(obstacles) == 0 or rects.shape[1] == 0:
        return np.zeros(len(rects), dtype=bool)
    a = rects[:, :, None, :]
    b = obstacles[None, None, :, :]
    sep = ((a[..., 2] + margin <= b[..., 0]) | (b[..., 2] + margin <= a[..., 0])
           | (a[..., 3] + margin <= b[..., 1]) | (b[..., 3] + margin <= a[..., 1]))
    return (~sep).any(axis=(1, 2))


def swept(a: np.ndarray, b: np.ndarray, rel: np.ndarray) -> np.ndarray:
    """Boxes ``rel`` (``(m, 4)`` or per candidate ``(n, m, 4)``) swept by the straight move
    of their origin from ``a`` to ``b`` (``(n, 2)`` each): ``(n, m, 4)``."""
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    rel = np.broadcast_to(rel, (len(a), *np.shape(rel)[-2:]))
    return np.stack([lo[:, None, 0] + rel[..., 0], lo[:, None, 1] + rel[..., 1],
                     hi[:, None, 0] + rel[..., 2], hi[:, None, 1] + rel[..., 3]], axis=-1)


def hand_rel(geometry: KitchenGeometry, held: SceneObject | None, grasps: np.ndarray | None,
             boxes: Sequence[Box] | None = None) -> np.ndarray:
    """The upright hand's boxes (default: open to the approach opening) and, if ``held``,
    the held object's boxes for each grasp ``(n, 2)``, relative to the gripper origin:
    ``(n, m, 4)`` (``(1, m, 4)`` without a held object)."""
    gripper = _rel_rects(geometry.gripper_boxes if boxes is None else boxes)[None]
    if held is None or grasps is None:
        return gripper
    offsets = np.concatenate([grasps, grasps], axis=1)[:, None, :]  # (n, 1, 4)
    carried = _rel_rects(held.boxes())[None] - offsets
    return np.concatenate([np.broadcast_to(gripper, (len(grasps), *gripper.shape[1:])),
                           carried], axis=1)


def bar_top(item: SceneObject) -> float | None:
    """Top of the bar a grasp holds (cup/bowl handle, spoon handle, stirrer rod), or
    ``None`` for objects without one (as :meth:`KitchenGeometry.grip_ok`)."""
    if item.kind in ("cup", "bowl"):
        return float(item.spec.height)
    if item.kind == "spoon":
        return float(item.spec.bowl_depth + item.spec.handle_length)
    if item.kind == "stirrer":
        return float(item.spec.length)
    return None


def grip_ok(geometry: KitchenGeometry, item: SceneObject, grasp_y: np.ndarray) -> np.ndarray:
    """:meth:`KitchenGeometry.grip_ok` for grasp heights ``(n,)``."""
    top = bar_top(item)
    if top is None:
        return np.ones(len(grasp_y), dtype=bool)
    g = geometry.spec.gripper
    palm_bottom = grasp_y + g.finger_length - g.tip
    return (grasp_y <= top - MIN_GRIP) & (palm_bottom >= top + 0.1)


def conf_heights(geometry: KitchenGeometry, grasp_y: np.ndarray | None) -> np.ndarray | float:
    """:meth:`KitchenGeometry.conf_height` for grasp heights ``(n,)`` (``None``: empty hand)."""
    base = geometry.ceiling + TRANSIT_MARGIN
    tip = geometry.spec.gripper.tip
    if grasp_y is None:
        return float(round(base + tip, 4))
    return _round(base + np.maximum(tip, grasp_y))


def _exclude(geometry: KitchenGeometry, pose: Point) -> list[str]:
    spot = geometry.spot_of(pose)
    return [spot] if spot else []


def pour_mask(geometry: KitchenGeometry, source: str, target: str, pose: Point,
              controls: np.ndarray) -> np.ndarray:
    """Which pour controls ``(n, 4)`` (``grasp_ratio, rel_x, rel_y, dangle``) of ``source``
    into ``target`` standing at ``pose`` pass :meth:`KitchenGeometry.pour_setup`: ``(n,)``."""
    controls = np.asarray(controls, dtype=float).reshape(-1, 4)
    item = geometry.spec.object(source)
    target_item = geometry.spec.object(target)
    n = len(controls)
    grasp_x = round(float(item.spec.handle_x), 4)
    grasp_y = _round([item.spec.grasp_height(float(r)) for r in controls[:, 0]])
    ok = grip_ok(geometry, item, grasp_y)
    start = np.stack([_round(pose[0] + controls[:, 1]),
                      _round(pose[1] + target_item.spec.height + controls[:, 2])], axis=1)
    height = np.maximum(conf_heights(geometry, grasp_y), start[:, 1])
    conf = np.stack([start[:, 0], height], axis=1)
    grasps = np.stack([np.full(n, grasp_x), grasp_y], axis=1)
    exclude = _exclude(geometry, pose)
    ok &= ~hits(swept(conf, start, hand_rel(geometry, item, grasps)),
                geometry.obstacles(exclude))
    swing_obstacles = geometry.obstacles([*exclude, "table"])
    walls = np.array([[pose[0] + b.cx - b.hw - 0.05, pose[1] + b.cy - b.hh - 0.05,
                       pose[0] + b.cx + b.hw + 0.05, pose[1] + b.cy + b.hh + 0.05]
                      for b in target_item.boxes()])
    hand_points = _corners(geometry.gripper_boxes)
    held_points = _corners(item.boxes())
    edges = _edge_points(item.boxes())
    steps = np.arange(N_ANGLES, dtype=float)
    for lo in range(0, n, CHUNK):
        rows = np.arange(lo, min(lo + CHUNK, n))
        rows = rows[ok[rows]]
        if len(rows) == 0:
            continue
        # Tilt about the gripper origin to ±dangle (towards the target, the skill's
        # sign(rel_x)), exactly as np.linspace does.
        dangle = controls[rows, 3]
        sense = pour_skill.tilt_sign(controls[rows, 1])[:, None]
        angles = steps[None, :] * (dangle / (N_ANGLES - 1))[:, None]
        angles[:, -1] = dangle
        angles = sense * angles
        c, s = np.cos(angles)[..., None], np.sin(angles)[..., None]  # (r, A, 1)
        sx, sy = start[rows, 0, None, None], start[rows, 1, None, None]
        grasp = grasps[rows][:, None, :]
        # Bounding box of gripper and held corners at each angle vs the furniture.
        local = np.concatenate([np.broadcast_to(hand_points[None], (len(rows),
                                                                    *hand_points.shape)),
                                held_points[None] - grasp], axis=1)[:, None]  # (r, 1, P, 2)
        wx = sx + c * local[..., 0] - s * local[..., 1]
        wy = sy + s * local[..., 0] + c * local[..., 1]
        boxes = np.stack([wx.min(-1), wy.min(-1), wx.max(-1), wy.max(-1)], axis=-1)
        blocked = hits(boxes, swing_obstacles)
        # Points along the held cup's edges must stay out of the target's walls. Only the
        # (candidate, angle) pairs whose held-cup bounding box meets a wall can: test those.
        held_x, held_y = wx[..., len(hand_points):], wy[..., len(hand_points):]
        near = ((held_x.max(-1)[..., None] > walls[:, 0]) & (held_x.min(-1)[..., None]
                                                             < walls[:, 2])
                & (held_y.max(-1)[..., None] > walls[:, 1]) & (held_y.min(-1)[..., None]
                                                               < walls[:, 3])).any(-1)
        near &= ~blocked[:, None]
        grazes = np.zeros(len(rows), dtype=bool)
        which, angle = np.nonzero(near)
        if len(which):
            points = edges[None] - grasp[which]  # (M, Q, 2)
            cm, sm = c[which, angle], s[which, angle]  # (M, 1)
            px = (start[rows[which], 0, None] + cm * points[..., 0] - sm * points[..., 1])
            py = (start[rows[which], 1, None] + sm * points[..., 0] + cm * points[..., 1])
            px, py = px[..., None], py[..., None]
            inside = ((px > walls[:, 0]) & (px < walls[:, 2]) & (py > walls[:, 1])
                      & (py < walls[:, 3])).any(axis=(1, 2))
            grazes[which[inside]] = True
        ok[rows] = ~(blocked | grazes)
    return ok


def scoop_mask(geometry: KitchenGeometry, spoon: str, bowl: str, pose: Point,
               controls: np.ndarray) -> np.ndarray:
    """Which scoop controls ``(n, 7)`` of ``spoon`` in ``bowl`` at ``pose`` pass
    :meth:`KitchenGeometry.scoop_setup`: ``(n,)``."""
    controls = np.asarray(controls, dtype=float).reshape(-1, 7)
    item = geometry.spec.object(spoon)
    cup = geometry.spec.object(bowl).spec
    config = scoop_skill.ScoopConfig()
    path = scoop_skill.waypoints(np.array([cup.width, cup.height]), controls, config)
    n = len(controls)
    grasp_x = round(float(item.spec.handle_x), 4)
    grasp_y = _round([scoop_skill.grasp_height(config, float(r)) for r in controls[:, 0]])
    ok = grip_ok(geometry, item, grasp_y)
    dy = pose[1] - geometry.top
    entry = np.stack([_round(pose[0] + path[:, 0, 0] + grasp_x),
                      _round(dy + path[:, 0, 1] + grasp_y)], axis=1)
    exit_ = np.stack([_round(pose[0] + path[:, -1, 0] + grasp_x),
                      _round(dy + path[:, -1, 1] + grasp_y)], axis=1)
    height = conf_heights(geometry, grasp_y)
    grasps = np.stack([np.full(n, grasp_x), grasp_y], axis=1)
    rel = hand_rel(geometry, item, grasps)
    obstacles = geometry.obstacles(_exclude(geometry, pose))
    down = swept(np.stack([entry[:, 0], height], axis=1), entry, rel)
    up = swept(exit_, np.stack([exit_[:, 0], height], axis=1), rel)
    return ok & ~hits(down, obstacles) & ~hits(up, obstacles)


def push_mask(geometry: KitchenGeometry, block: str, pose: Point, edge: str,
              controls: np.ndarray) -> np.ndarray:
    """Which push controls ``(n, 4)`` (``rx, ry, angle, duration``) of ``block`` at ``pose``
    off ``edge`` pass :meth:`KitchenGeometry.push_setup`: ``(n,)``."""
    controls = np.asarray(controls, dtype=float).reshape(-1, 4)
    rx, angle, duration = controls[:, 0], controls[:, 2], controls[:, 3]
    direction = math.copysign(1.0, geometry.edge_x(edge) - pose[0])
    travel = PUSH_SPEED * duration * np.cos(angle)
    ok = (direction * travel > 0) & (direction * rx < 0)
    n = len(controls)
    y = np.full(n, geometry.push_height(block, pose))
    start = np.stack([_round(pose[0] + rx + direction * geometry.push_offset(block)), y], axis=1)
    end = np.stack([_round(start[:, 0] + travel), y], axis=1)
    top = np.full(n, conf_heights(geometry, None))
    conf = np.stack([start[:, 0], top], axis=1)
    lift = np.stack([end[:, 0], top], axis=1)
    rel = hand_rel(geometry, None, None, geometry.pusher_boxes)
    obstacles = geometry.obstacles(_exclude(geometry, pose))
    for a, b in ((conf, start), (start, end), (end, lift)):
        ok &= ~hits(swept(a, b, rel), obstacles)
    return ok
