"""Grasps of a vertical cylinder (cups, bowls held by the body, handles) for the Panda hand.

Object frame: cylinder axis along +z; ``base_z`` is the z of the cylinder's bottom face in
the object frame (``-height / 2`` for pybullet's centred cylinders, ``0`` for kitchenware
whose origin is at the base). Gripper frame: the Panda grasp target (link 11) with z the
approach direction out of the palm and y the fingers' closing axis.

A :class:`Grasp` stores ``tool_in_gripper``, the object's pose in the gripper frame, so
``gripper_pose = object_pose @ tool_in_gripper.inverse()``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ltamp_cli.backends.pybullet.robot.arm import PANDA_FINGER_TRAVEL
from ltamp_cli.backends.pybullet.robot.pose import Pose

MAX_GRASP_WIDTH = 2 * PANDA_FINGER_TRAVEL
"""Widest object the Panda gripper closes around (metres)."""


@dataclass(frozen=True)
class Grasp:
    """``kind`` is ``"side"`` or ``"top"``; ``width`` the finger gap when closed (metres)."""

    kind: str
    tool_in_gripper: Pose
    width: float

    def gripper_pose(self, object_pose: Pose) -> Pose:
        """World pose of the grasp target when the object is at ``object_pose``."""
        return object_pose @ self.tool_in_gripper.inverse()

    def pregrasp_pose(self, object_pose: Pose, retreat: float = 0.1) -> Pose:
        """Gripper pose backed off by ``retreat`` metres against the approach direction."""
        return self.gripper_pose(object_pose) @ Pose(np.array([0.0, 0.0, -retreat]))


def _grasp_from_frame(
    kind: str, position: np.ndarray, x_axis: np.ndarray, y_axis: np.ndarray, width: float
) -> Grasp:
    z_axis = np.cross(x_axis, y_axis)
    gripper_in_object = np.eye(4)
    gripper_in_object[:3, 0] = x_axis
    gripper_in_object[:3, 1] = y_axis
    gripper_in_object[:3, 2] = z_axis
    gripper_in_object[:3, 3] = position
    return Grasp(kind, Pose.from_matrix(gripper_in_object).inverse(), width)


def _check_cylinder(radius: float, height: float) -> None:
    if radius <= 0 or height <= 0:
        raise ValueError("cylinder radius and height must be positive")
    if 2 * radius > MAX_GRASP_WIDTH:
        raise ValueError(
            f"cylinder diameter {2 * radius:.3f} m exceeds the gripper's {MAX_GRASP_WIDTH} m"
        )


def cylinder_side_grasps(
    radius: float,
    height: float,
    *,
    base_z: float | None = None,
    grasp_height: float = 0.5,
    n_yaw: int = 8,
) -> tuple[Grasp, ...]:
    """Horizontal grasps around the cylinder at ``grasp_height`` × ``height`` above its base.

    ``n_yaw`` approach directions evenly spaced around the axis, each with the hand upright
    and flipped: ``2 * n_yaw`` grasps. The grasp target lies on the axis, fingers closing
    across the diameter. Raises ``ValueError`` for a cylinder wider than the gripper.
    """
    _check_cylinder(radius, height)
    if not 0.0 <= grasp_height <= 1.0 or n_yaw < 1:
        raise ValueError("grasp_height must be in [0, 1] and n_yaw >= 1")
    bottom = -height / 2 if base_z is None else base_z
    centre = np.array([0.0, 0.0, bottom + grasp_height * height])
    grasps = []
    for yaw in np.linspace(0.0, 2 * np.pi, n_yaw, endpoint=False):
        inward = -np.array([np.cos(yaw), np.sin(yaw), 0.0])
        tangent = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
        for flip in (1.0, -1.0):
            y_axis = flip * tangent
            x_axis = np.cross(y_axis, inward)
            grasps.append(_grasp_from_frame("side", centre, x_axis, y_axis, 2 * radius))
    return tuple(grasps)


def cylinder_top_grasps(
    radius: float,
    height: float,
    *,
    base_z: float | None = None,
    depth: float = 0.02,
    n_yaw: int = 4,
) -> tuple[Grasp, ...]:
    """Grasps from above, fingers closing across the diameter ``depth`` m below the top.

    The gripper is symmetric under a half turn, so ``n_yaw`` yaws span ``[0, π)``.
    Raises ``ValueError`` for a cylinder wider than the gripper.
    """
    _check_cylinder(radius, height)
    if depth < 0 or n_yaw < 1:
        raise ValueError("depth must be >= 0 and n_yaw >= 1")
    bottom = -height / 2 if base_z is None else base_z
    position = np.array([0.0, 0.0, bottom + height - min(depth, height / 2)])
    down = np.array([0.0, 0.0, -1.0])
    grasps = []
    for yaw in np.linspace(0.0, np.pi, n_yaw, endpoint=False):
        y_axis = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
        x_axis = np.cross(y_axis, down)
        grasps.append(_grasp_from_frame("top", position, x_axis, y_axis, 2 * radius))
    return tuple(grasps)


def _both_hands(kind: str, position: np.ndarray, approach: np.ndarray, closing: np.ndarray,
                width: float) -> tuple[Grasp, Grasp]:
    """The grasp with gripper ``z = approach`` and ``y = closing``, and the same grasp with
    the hand turned half a turn about the approach (``y = -closing``)."""
    return tuple(  # type: ignore[return-value]
        _grasp_from_frame(kind, position, np.cross(sign * closing, approach), sign * closing,
                          width)
        for sign in (1.0, -1.0)
    )


def rim_grasps(
    top_radius: float,
    height: float,
    thickness: float,
    *,
    depth: float = 0.015,
    n_yaw: int = 8,
    lean: float = 0.0,
) -> tuple[Grasp, ...]:
    """Grasps pinching a vessel's wall at its rim from above (one finger inside, one outside),
    for a vessel of any diameter; object frame: base centre at the origin, axis ``+z``.

    ``top_radius`` is the outer radius at the rim, ``thickness`` the wall's (the finger gap),
    ``depth`` how far below the rim the grasp target sits. ``n_yaw`` points around the rim,
    each with the hand both ways round: ``2 * n_yaw`` grasps, approach ``-z``, fingers
    closing radially. ``lean`` (radians, ``[0, π/2)``) tilts the hand outwards about the
    rim's tangent: the approach comes from above and outside (``-cos(lean) z - sin(lean)
    radial``) and the fingers close across the wall's top corner, so the hand sticks out
    sideways rather than along the cup's axis. Units: metres.
    """
    if min(top_radius, height, thickness) <= 0 or not 0 <= depth < height or n_yaw < 1:
        raise ValueError("rim grasps need positive sizes, 0 <= depth < height, n_yaw >= 1")
    if not 0.0 <= lean < np.pi / 2:
        raise ValueError("lean must be in [0, π/2)")
    width = thickness / np.cos(lean)
    if width > MAX_GRASP_WIDTH:
        raise ValueError(f"wall {width:.3f} m exceeds the gripper's {MAX_GRASP_WIDTH} m")
    up = np.array([0.0, 0.0, 1.0])
    middle = top_radius - thickness / 2.0
    grasps: list[Grasp] = []
    for yaw in np.linspace(0.0, 2 * np.pi, n_yaw, endpoint=False):
        radial = np.array([np.cos(yaw), np.sin(yaw), 0.0])
        position = middle * radial + np.array([0.0, 0.0, height - depth])
        approach = -np.cos(lean) * up - np.sin(lean) * radial
        closing = np.cos(lean) * radial - np.sin(lean) * up
        grasps.extend(_both_hands("rim", position, approach, closing, width))
    return tuple(grasps)


def bar_grasps(
    centre: np.ndarray,
    axes: np.ndarray,
    half_extents: np.ndarray,
) -> tuple[Grasp, ...]:
    """Grasps of a thin box (a spoon's handle) around its long axis at ``centre`` ``(3,)``.

    ``axes`` ``(3, 3)``: the box's unit axes as columns (object frame), ``half_extents``
    ``(3,)`` along them (metres); the longest is the bar's axis. Fingers close across each
    of the two short sides that fits the gripper, approaching along the other short axis
    from either side, hand both ways round: up to 8 grasps, the narrowest closing first.
    """
    axes = np.asarray(axes, dtype=float)
    half = np.asarray(half_extents, dtype=float)
    short = [int(i) for i in np.argsort(half)[:2]]
    grasps: list[Grasp] = []
    for closing, approach in ((short[0], short[1]), (short[1], short[0])):
        width = 2.0 * float(half[closing])
        if width > MAX_GRASP_WIDTH:
            continue
        for side in (1.0, -1.0):
            grasps.extend(_both_hands("bar", np.asarray(centre, dtype=float),
                                      side * axes[:, approach], axes[:, closing], width))
    return tuple(grasps)


def box_top_grasps(half_extents: np.ndarray, pitch: float = 0.0) -> tuple[Grasp, ...]:
    """Grasps from above of a box centred on its frame (a fingertip pad), grasp target at
    its centre, fingers closing along ``y`` then ``x`` (each side that fits), hand both
    ways round. ``half_extents`` ``(3,)`` metres. With ``pitch`` (radians, ``0 < pitch <
    π/2``) only the fingers closing along ``y`` are used and the approach leans towards
    ``+x`` (``(sin pitch, 0, -cos pitch)``): the palm stays behind the box's ``+x`` face."""
    half = np.asarray(half_extents, dtype=float)
    down = np.array([np.sin(pitch), 0.0, -np.cos(pitch)])
    grasps: list[Grasp] = []
    for axis in ((1,) if pitch else (1, 0)):
        if 2.0 * half[axis] > MAX_GRASP_WIDTH:
            continue
        closing = np.eye(3)[axis]
        grasps.extend(_both_hands("top", np.zeros(3), down, closing, 2.0 * float(half[axis])))
    return tuple(grasps)
