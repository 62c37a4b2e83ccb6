"""Skill tool paths placed in the kitchen: the skill-frame path of a control (learned pour and
scoop) or an engineered tool path (dump, stir, push), turned and moved onto the target object
standing on the table.

The learned skills are symmetric about the target's vertical axis (revolved bowls), so a skill
path may be turned by ``ψ`` about the target without changing the physics the skill model
learned; pours may also turn the (revolved) cup by ``φ`` about its own axis. All functions
return world poses of the tool's object frame (the spoon, stirrer or cup base frame; for push,
the gripper's grasp-target frame).
"""

from __future__ import annotations

import math

import numpy as np

from ltamp_cli.backends.kitchenware_geometry import SpoonDims
from ltamp_cli.backends.pybullet.paths import rotation_about_axis
from ltamp_cli.backends.pybullet.robot.pose import Pose
from ltamp_cli.backends.pybullet.skills.pour import PourContext, pour_path
from ltamp_cli.backends.pybullet.skills.scoop import ScoopContext, scoop_path
from ltamp_cli.backends.pybullet.tamp.planning import pose_of
from ltamp_cli.backends.pybullet.tamp.scene import XY, ObjectSpec

#: Height (m) above a container's rim of an upright spoon or stirrer entering/leaving it.
ABOVE_RIM_M = 0.05
#: How far the spoon rolls (radians about its own ``y`` axis, along the handle) to dump its
#: contents: past the side, so that the shallow head empties, while the hand stays beside
#: the spoon rather than under it.
DUMP_ANGLE_RAD = math.radians(100.0)
#: Stirrer: its tip this high (m) above the cup's floor, circling this fraction of the
#: inner radius, with this many waypoints per turn and this many turns.
STIR_TIP_CLEARANCE_M = 0.015
STIR_RADIUS_FRACTION = 0.45
STIR_WAYPOINTS = 8
STIR_TURNS = 2
#: The kitchen stir's tip speed (m/s): the stir skill's ``speed`` control (its trials move the
#: tip at it, :func:`~ltamp_cli.backends.skills3d.stir.run_stir`), which the executor keeps.
STIR_SPEED_M_S = 0.1
#: Push: lowest hand (grasp-target) height (m) above the table, clearance (m) behind the
#: object before contact, and the lift (m) before and after. The closed fingertips reach
#: ``FINGERTIP_BELOW_M`` below the grasp target and push ``PUSH_BELOW_TOP_M`` below the
#: object's top, so the palm (~5 cm above the fingertips) passes above a bowl's rim: at
#: the old fixed 3.5 cm the palm skimmed push_to_reach's 7 cm bowl rim by 2 mm.
PUSH_HEIGHT_M = 0.035
FINGERTIP_BELOW_M = 0.011
PUSH_BELOW_TOP_M = 0.02
PUSH_GAP_M = 0.03
PUSH_LIFT_M = 0.1
#: Half the closed fingers' thickness along the push direction (m).
FINGER_HALF_M = 0.012
#: Gap (m) between the fingers pushing a round object (cup, bowl) with the fingers across
#: the push line: the Panda's full opening, so the two fingers touch the wall ~4 cm either
#: side of the line. Closed, they touch it at one point, and a round object pushed at one
#: point is unstable: the smallest offset turns and slides it off the line, and the error
#: grows with the stroke (push_to_reach seed 1: the bowl came to rest 0.187 m from its
#: target after a 0.66 m push, 0.12 m off the line, the closed fingers past its centre).
#: Two contacts either side of the line push it back onto the line (the same push with the
#: fingers open: 1 mm off the line, 0.013 m from the target).
PUSH_FINGER_GAP_M = 0.08
#: ...but at most this fraction of a round object's diameter (footprint), so that the open
#: fingers touch it either side of the line rather than straddle it: a 7 cm cup would pass
#: between fingers 8 cm apart and meet the hand's body. For the 0.2 m bowl the full opening.
PUSH_FINGER_GAP_FRACTION = 0.8
#: Pushed kinds that are round (revolved about their vertical axis).
ROUND_KINDS = ("cup", "bowl")


def pour_context(cup: ObjectSpec, bowl: ObjectSpec) -> np.ndarray:
    """The GoodPour context ``(6,)`` of pouring ``cup`` into ``bowl`` (skill order)."""
    return PourContext(bowl.vessel(), cup.vessel()).to_array()


def pour_tool_poses(cup: ObjectSpec, bowl: ObjectSpec, bowl_xy: XY, table_z: float,
                    control: np.ndarray, psi: float, phi: float) -> list[Pose]:
    """World poses of the cup's base frame along the pour of ``control`` (5,)."""
    path = pour_path(PourContext(bowl.vessel(), cup.vessel()), np.asarray(control, dtype=float))
    frame = pose_of(bowl_xy, table_z, yaw=psi)
    spin = Pose.from_euler(np.zeros(3), yaw=phi)
    return [frame @ Pose(position, quaternion) @ spin
            for position, quaternion in zip(path.positions, path.quaternions, strict=True)]


def scoop_context(bowl: ObjectSpec, spoon: ObjectSpec) -> np.ndarray:
    """The GoodScoop context ``(4,)`` of scooping from ``bowl`` with ``spoon``."""
    return ScoopContext(bowl.vessel(), SpoonDims(float(spoon.dims["length"]))).to_array()


def scoop_tool_poses(bowl: ObjectSpec, spoon: ObjectSpec, bowl_xy: XY, table_z: float,
                     control: np.ndarray, psi: float) -> list[Pose]:
    """World poses of the spoon frame along the scoop of ``control`` (5,), preceded by the
    spoon upright above the entry point (so that the arm reaches the scoop carrying the spoon
    level, and tilts it over the bowl)."""
    context = ScoopContext(bowl.vessel(), SpoonDims(float(spoon.dims["length"])))
    path = scoop_path(context, np.asarray(control, dtype=float))
    frame = pose_of(bowl_xy, table_z, yaw=psi)
    poses = [frame @ Pose(position, quaternion)
             for position, quaternion in zip(path.positions, path.quaternions, strict=True)]
    upright = frame @ Pose(path.positions[0] + np.array([0.0, 0.0, ABOVE_RIM_M]))
    return [upright, *poses]


def dump_tool_poses(spoon: ObjectSpec, cup: ObjectSpec, cup_xy: XY, table_z: float,
                    psi: float, sign: float = 1.0, steps: int = 6) -> list[Pose]:
    """World poses of the spoon frame turning over above ``cup``: the head's centre stays
    ``ABOVE_RIM_M`` over the cup's axis while the spoon rolls by ``sign * DUMP_ANGLE_RAD``
    about its own ``y`` axis (the handle's direction), in ``steps``; the spoon's yaw about
    the cup is ``psi``."""
    head = SpoonDims(float(spoon.dims["length"])).head()
    pivot = np.array([0.0, 0.0, head.height / 2.0])  # the head's centre, spoon frame
    frame = pose_of(cup_xy, table_z, yaw=psi)
    centre = np.array([0.0, 0.0, cup.height + ABOVE_RIM_M + head.height])
    poses = []
    for angle in np.linspace(0.0, sign * DUMP_ANGLE_RAD, steps + 1):
        rotation = rotation_about_axis("y", float(angle))
        turned = Pose(np.zeros(3), rotation)
        # Place so that the pivot sits at ``centre``: p = centre - R @ pivot.
        position = centre - turned.rotation() @ pivot
        poses.append(frame @ Pose(position, rotation))
    return poses


def stir_tool_poses(stirrer: ObjectSpec, cup: ObjectSpec, cup_xy: XY, table_z: float,
                    phi: float) -> list[Pose]:
    """World poses of the upright stirrer (rod base frame, turned ``phi`` about the rod):
    above the cup's centre, down to near its floor, ``STIR_TURNS`` circles, back to the
    centre. The executor follows them forward and then backward (up out of the cup)."""
    dims = cup.vessel()
    tip_z = dims.thickness + STIR_TIP_CLEARANCE_M
    radius = STIR_RADIUS_FRACTION * (float(dims.outer_radius_at(tip_z)) - dims.thickness)
    spin = Pose.from_euler(np.zeros(3), yaw=phi)
    frame = pose_of(cup_xy, table_z)
    above = cup.height + ABOVE_RIM_M
    points = [np.array([0.0, 0.0, above]), np.array([0.0, 0.0, tip_z])]
    for k in range(STIR_TURNS * STIR_WAYPOINTS + 1):
        angle = 2.0 * math.pi * k / STIR_WAYPOINTS
        points.append(np.array([radius * math.cos(angle), radius * math.sin(angle), tip_z]))
    points.append(np.array([0.0, 0.0, tip_z]))
    return [frame @ Pose(point) @ spin for point in points]


def push_hand_height(obj: ObjectSpec) -> float:
    """Height (m) of the grasp target above the table while pushing ``obj``."""
    return max(PUSH_HEIGHT_M, obj.height - PUSH_BELOW_TOP_M + FINGERTIP_BELOW_M)


def fingers_across(finger_axis: np.ndarray, direction: np.ndarray) -> bool:
    """Is the line through the two fingers (``finger_axis``, world, (2,) or (3,)) closer to
    across the push ``direction`` (world xy, (2,)) than along it (over 45°)?"""
    axis = np.asarray(finger_axis, dtype=float)[:2]
    d = np.asarray(direction, dtype=float)[:2]
    norm = float(np.linalg.norm(axis) * np.linalg.norm(d))
    return norm > 0.0 and abs(float(axis @ d)) / norm < math.sqrt(0.5)


def push_finger_gap(obj: ObjectSpec, across: bool) -> float:
    """Gap (m) between the fingers pushing ``obj``: for a round object pushed with the
    fingers across the line :data:`PUSH_FINGER_GAP_M`, at most
    :data:`PUSH_FINGER_GAP_FRACTION` of its footprint's diameter; closed (0) otherwise (a
    flat face is stable under one contact; fingers along the line would put the front one
    ahead)."""
    if not across or obj.kind not in ROUND_KINDS:
        return 0.0
    return min(PUSH_FINGER_GAP_M, PUSH_FINGER_GAP_FRACTION * 2.0 * float(obj.footprint()[0]))


def push_contact_distance(obj: ObjectSpec, gap: float) -> float:
    """Distance (m) along the push line from the hand (grasp target) to ``obj``'s centre
    while the fingers, ``gap`` apart across the line, touch it: ``r + FINGER_HALF_M`` for
    closed fingers (``r`` the footprint's half extent), ``sqrt(r² - (gap/2)²) +
    FINGER_HALF_M`` for a round object touched by both open fingers' inner edges."""
    r = float(obj.footprint()[0])
    half = min(gap / 2.0, r) if obj.kind in ROUND_KINDS else 0.0
    return math.sqrt(r * r - half * half) + FINGER_HALF_M


def push_direction(start: XY, goal: XY) -> np.ndarray:
    """Unit vector (world xy, (2,)) from ``start`` to ``goal`` (any unit vector if equal)."""
    s, g = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    return (g - s) / max(float(np.linalg.norm(g - s)), 1e-9)


def hand_finger_axis(hand_yaw: float) -> np.ndarray:
    """The line through the fingers (world xy, (2,)) of the palm-down hand turned by
    ``hand_yaw`` (radians) about the vertical: the hand's ``y`` axis."""
    return np.array([-math.sin(hand_yaw), math.cos(hand_yaw)])


def push_hand_gap(obj: ObjectSpec, start: XY, goal: XY, hand_yaw: float) -> float:
    """Finger gap (m) of the push of ``obj`` from ``start`` to ``goal`` with the hand turned
    by ``hand_yaw``: :func:`push_finger_gap` of whether the fingers lie across the line. The
    gap :func:`push_hand_poses` plans the stroke for, that the planner's collision checks
    give the hand (:attr:`~.values.ArmPath.finger_gap`) and that the executor opens."""
    return push_finger_gap(obj, fingers_across(hand_finger_axis(hand_yaw),
                                               push_direction(start, goal)))


def push_holds_line(obj: ObjectSpec, start: XY, goal: XY, hand_yaw: float) -> bool:
    """Can the push's contact hold ``obj`` on its line? A flat-faced object (block) under
    any hand yaw (one contact on a face); a round one (cup, bowl) only with the fingers
    open across the line (two contacts either side of it). Closed fingers along the line
    touch a round wall at one point: the object turns and slides off the line by an amount
    that varies from push to push (push_to_reach PyBullet seeds 3 and 5: 0.049 and 0.039 m
    from the target, tolerance 0.03; seeds 0, 2, 6: 0.015-0.029 m)."""
    return obj.kind not in ROUND_KINDS or push_hand_gap(obj, start, goal, hand_yaw) > 0.0


def push_hand_poses(obj: ObjectSpec, start: XY, goal: XY, table_z: float, hand_yaw: float
                    ) -> list[Pose]:
    """World poses of the gripper (palm down) pushing ``obj`` in a straight line from
    ``start`` to ``goal``: above the point behind it, down, along the line until the
    object's centre reaches ``goal``, back off by ``PUSH_GAP_M`` and up (away from the
    object, so the hand does not hover over it). ``hand_yaw`` turns the hand about the
    vertical: at the line's heading the fingers (along the hand's ``y``) lie across the
    line, and a round object is pushed with them :func:`push_finger_gap` apart (the
    executor opens them the same way); otherwise they are closed."""
    s, g = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    direction = push_direction(start, goal)
    behind = push_contact_distance(obj, push_hand_gap(obj, start, goal, hand_yaw))
    # The approach starts clear of the whole footprint (as for closed fingers) whatever the
    # gap: open fingers then meet the wall a little later, which nothing depends on.
    clear = push_contact_distance(obj, 0.0)
    down = Pose.from_euler(np.zeros(3), roll=math.pi, yaw=0.0)
    turn = Pose.from_euler(np.zeros(3), yaw=hand_yaw)
    z = table_z + push_hand_height(obj)

    def at(xy: np.ndarray, height: float) -> Pose:
        return Pose(np.array([xy[0], xy[1], height])) @ turn @ down

    first = s - direction * (clear + PUSH_GAP_M)
    last = g - direction * behind
    back = last - direction * PUSH_GAP_M
    return [at(first, z + PUSH_LIFT_M), at(first, z), at(last, z), at(back, z),
            at(back, z + PUSH_LIFT_M)]
