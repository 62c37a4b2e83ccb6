"""Grasps of the Kitchen3D objects for the Panda hand.

Cups are held from the side at mid height, the hand horizontal and approaching along ``±x``
or 45° off it (the directions an arm at ``∓x`` can reach), upright or flipped. Blocks are
held from above with the fingers closing across their narrower side. Tools are held from
above: the spoon by its handle (the palm facing the handle's top surface, the fingers closing
across its width), the stirrer by its top end (the rod along the approach axis). The grasp
value ``(kind, index)`` indexes :func:`object_grasps`.
"""

from __future__ import annotations

import math

import numpy as np

from ltamp_cli.backends.kitchenware_geometry import SpoonDims
from ltamp_cli.backends.pybullet.robot.grasps import (
    MAX_GRASP_WIDTH,
    Grasp,
    cylinder_side_grasps,
)
from ltamp_cli.backends.pybullet.robot.pose import Pose
from ltamp_cli.backends.pybullet.tamp.scene import ObjectSpec

#: Side-grasp approach yaws (radians, direction the palm moves in the object frame) for the
#: arm at ``-x`` (arm 0); the arm at ``+x`` uses them turned by π.
SIDE_APPROACH_YAWS = (0.0, math.pi / 4, -math.pi / 4)
TOP_GRASP_DEPTH_M = 0.025
#: Side grasps hold a cup this far up its height: low, so the hand stays clear of the
#: receptacle's rim while the cup tilts over it.
GRASP_HEIGHT = 0.45
#: Where along the spoon's handle (fraction of its length from the head) the hand holds it.
SPOON_HANDLE_FRACTION = 0.7
#: How far below the stirrer's top end (m) the fingertips hold it.
STIRRER_GRIP_DEPTH_M = 0.02
#: Stirrer hand yaws (radians about the rod): the rod is symmetric, so several are offered.
STIRRER_YAWS = (0.0, math.pi / 2)


def approach_direction(grasp: Grasp) -> np.ndarray:
    """Unit vector ``(3,)`` (object frame) along which the palm approaches."""
    return grasp.tool_in_gripper.inverse().rotation()[:, 2]


def _side_grasps(spec: ObjectSpec, n_arms: int) -> list[Grasp]:
    dims = spec.vessel()
    radius = float(dims.outer_radius_at(dims.height * GRASP_HEIGHT))
    if 2 * radius > MAX_GRASP_WIDTH:
        return []
    candidates = cylinder_side_grasps(radius, dims.height, base_z=0.0, grasp_height=GRASP_HEIGHT,
                                      n_yaw=8)
    chosen = []
    for arm in range(n_arms):
        for yaw in SIDE_APPROACH_YAWS:
            yaw += math.pi * arm
            want = np.array([math.cos(yaw), math.sin(yaw), 0.0])
            chosen.extend(g for g in candidates if float(approach_direction(g) @ want) > 0.999)
    return chosen


def _block_top_grasps(spec: ObjectSpec) -> list[Grasp]:
    sx, sy, sz = (float(v) for v in spec.dims["size"])
    across_x = sx <= sy  # fingers close along the narrower horizontal side
    width = min(sx, sy)
    if width > MAX_GRASP_WIDTH:
        return []
    down = np.array([0.0, 0.0, -1.0])
    grasps = []
    for sign in (1.0,):  # the other sign is the same grasp turned by π
        y_axis = sign * (np.array([1.0, 0.0, 0.0]) if across_x else np.array([0.0, 1.0, 0.0]))
        x_axis = np.cross(y_axis, down)
        frame = np.eye(4)
        frame[:3, 0], frame[:3, 1], frame[:3, 2] = x_axis, y_axis, down
        frame[:3, 3] = (0.0, 0.0, sz - min(TOP_GRASP_DEPTH_M, sz / 2))
        grasps.append(Grasp("top", Pose.from_matrix(frame).inverse(), width))
    return grasps


def _frame_grasp(kind: str, position: np.ndarray, x_axis: np.ndarray, y_axis: np.ndarray,
                 width: float) -> Grasp:
    """The grasp whose gripper frame (object frame) has these ``x``/``y`` axes at ``position``
    (``z`` = ``x × y`` is the approach, out of the palm)."""
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1] = x_axis, y_axis
    frame[:3, 2] = np.cross(x_axis, y_axis)
    frame[:3, 3] = position
    return Grasp(kind, Pose.from_matrix(frame).inverse(), width)


def _spoon_grasps(spec: ObjectSpec) -> list[Grasp]:
    dims = SpoonDims(float(spec.dims["length"]))
    head = dims.head()
    c, s = math.cos(dims.handle_angle), math.sin(dims.handle_angle)
    along = np.array([0.0, c, s])  # the handle's direction, away from the head
    start = np.array([0.0, head.top_radius - head.thickness, head.height])
    handle_length = max(dims.length - head.top_diameter, 0.02)
    point = start + along * handle_length * SPOON_HANDLE_FRACTION
    across = np.array([1.0, 0.0, 0.0])
    # Palm over the handle's top face: approach = -normal; the fingers close across the
    # handle's width. Both hand orientations about the approach axis are offered.
    return [_frame_grasp("handle", point, sign * along, sign * across, 0.012)
            for sign in (1.0, -1.0)]


def _stirrer_grasps(spec: ObjectSpec) -> list[Grasp]:
    length = float(spec.dims.get("length", 0.2))
    point = np.array([0.0, 0.0, length - STIRRER_GRIP_DEPTH_M])
    grasps = []
    for yaw in STIRRER_YAWS:
        x_axis = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        y_axis = np.cross(np.array([0.0, 0.0, -1.0]), x_axis)  # so that x × y = -z
        grasps.append(_frame_grasp("top", point, x_axis, y_axis, 0.008))
    return grasps


def object_grasps(spec: ObjectSpec, n_arms: int = 1) -> list[Grasp]:
    """Every grasp of ``spec`` usable by ``n_arms`` arms (empty if it cannot be picked)."""
    if spec.fixed:
        return []
    if spec.kind == "cup":
        return _side_grasps(spec, n_arms)
    if spec.kind == "block":
        return _block_top_grasps(spec)
    if spec.kind == "spoon":
        return _spoon_grasps(spec)
    if spec.kind == "stirrer":
        return _stirrer_grasps(spec)
    return []
