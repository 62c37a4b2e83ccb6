"""Collision checking of a Panda configuration with ``getClosestPoints``.

A check moves the arm kinematically to ``q``, places the attached (grasped) body at
``EE pose @ grasp`` and queries pybullet for closest points, cheapest tests first:

1. the attached body's tilt (|roll|, |pitch| ≤ limit) when it carries contents;
2. arm (without its fixed base link) against each obstacle body;
3. attached body against each obstacle and against the arm links other than the hand;
4. arm self-collision over :data:`PANDA_SELF_COLLISION_PAIRS`.

A ``getClosestPoints`` query costs ~10-85 µs (a 16-piece bowl is the dearest); each is
preceded by an axis-aligned bounding-box test (pybullet's boxes, ~1.5 µs a link): when no
box of one body, grown by the query distance, overlaps the other's, nothing can be within
that distance, so the query is skipped without changing the check's answer.

The attachment is *kinematic* (the body is re-posed at every check); during simulated
execution use :func:`attach_fixed_constraint` for a rigid pybullet constraint instead.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pybullet

from ltamp_cli.backends.pybullet.robot.arm import (
    PANDA_HAND_LINK,
    PANDA_HAND_LINKS,
    PANDA_HOME,
    PandaArm,
)
from ltamp_cli.backends.pybullet.robot.pose import Pose, tilt_roll_pitch

CARRY_TILT_LIMIT = np.pi / 6
"""Largest |roll| and |pitch| (radians) of a tool carrying contents (paper, section 6)."""

PANDA_SELF_COLLISION_PAIRS: tuple[tuple[int, int], ...] = (
    *((a, b) for a in (-1, 0, 1) for b in (4, 5, 6, 8, 9, 10)),
    (4, 6),
    (4, 8),
    (4, 9),
    (4, 10),
)
"""Link pairs that can collide. Derived like an SRDF's disabled-collision list: over 2,000
uniform random configurations (``sample_self_collision_pairs``) these and only these
non-adjacent pairs were ever in contact; adjacent pairs touch always and are skipped."""


@dataclass(frozen=True)
class AttachedBody:
    """A body held by the gripper. ``grasp`` is the body's pose in the grasp-target frame.

    ``carries_contents``: the body holds particles, so its tilt is limited.
    """

    body_id: int
    grasp: Pose
    carries_contents: bool = False


Box = tuple[tuple[float, float, float], tuple[float, float, float]]
"""An axis-aligned box ``((x_lo, y_lo, z_lo), (x_hi, y_hi, z_hi))`` in metres."""
_UNBOUNDED = 1e30


def _overlap(a: Box, b: Box, margin: float) -> bool:
    """Do boxes ``a`` and ``b`` overlap once ``b`` is grown by ``margin`` metres?"""
    (alx, aly, alz), (ahx, ahy, ahz) = a
    (blx, bly, blz), (bhx, bhy, bhz) = b
    return (alx <= bhx + margin and ahx >= blx - margin and aly <= bhy + margin
            and ahy >= bly - margin and alz <= bhz + margin and ahz >= blz - margin)


@dataclass
class _RigidBox:
    """Bounding box of a body whose links cannot move relative to its base, cached for as
    long as the base's pose is unchanged (movable kitchenware is re-posed between queries)."""

    body: int
    client: int
    links: tuple[int, ...]
    #: A plane's box is unbounded; an upright plane (the floor) bounds ``z`` by its height.
    plane: bool = False
    _key: tuple[tuple[float, ...], tuple[float, ...]] | None = field(default=None, repr=False)
    _box: Box | None = field(default=None, repr=False)

    @staticmethod
    def of(body: int, client: int) -> _RigidBox | None:
        """The cached box of ``body``, or None when some joint of it can move (an arm)."""
        n_joints = pybullet.getNumJoints(body, physicsClientId=client)
        for joint in range(n_joints):
            info = pybullet.getJointInfo(body, joint, physicsClientId=client)
            if info[2] != pybullet.JOINT_FIXED:
                return None
        shapes = pybullet.getCollisionShapeData(body, -1, physicsClientId=client)
        plane = n_joints == 0 and len(shapes) == 1 and shapes[0][2] == pybullet.GEOM_PLANE
        return _RigidBox(body, client, (-1, *range(n_joints)), plane)

    def box(self) -> Box:
        key = pybullet.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
        if key != self._key or self._box is None:
            self._key, self._box = key, self._compute(key)
        return self._box

    def _compute(self, base: tuple[tuple[float, ...], tuple[float, ...]]) -> Box:
        if self.plane:
            upright = abs(abs(base[1][3]) - 1.0) < 1e-9
            top = base[0][2] if upright else _UNBOUNDED
            return ((-_UNBOUNDED, -_UNBOUNDED, -_UNBOUNDED), (_UNBOUNDED, _UNBOUNDED, top))
        boxes = [pybullet.getAABB(self.body, link, physicsClientId=self.client)
                 for link in self.links]
        low = tuple(min(b[0][i] for b in boxes) for i in range(3))
        high = tuple(max(b[1][i] for b in boxes) for i in range(3))
        return (low, high)  # type: ignore[return-value]


class ArmCollisionChecker:
    """``checker(q) -> bool``: True when configuration ``q`` (shape ``(7,)``) is valid.

    ``obstacles`` are pybullet body ids (the table, other arms, kitchenware). A contact
    counts as a collision when the signed distance is below ``clearance - touch_tolerance``
    (metres): ``touch_tolerance`` lets a grasped cup still resting on the table, or two
    bodies placed exactly in contact, pass. ``tilt_limit`` (radians) applies to an attached
    body that carries contents. The arm is left at the last checked configuration.
    """

    def __init__(
        self,
        arm: PandaArm,
        obstacles: Sequence[int] = (),
        attached: AttachedBody | None = None,
        *,
        clearance: float = 0.0,
        touch_tolerance: float = 1e-3,
        self_collision: bool = True,
        tilt_limit: float = CARRY_TILT_LIMIT,
    ) -> None:
        if clearance < 0 or touch_tolerance < 0:
            raise ValueError("clearance and touch_tolerance must be >= 0")
        self.arm = arm
        self.obstacles = tuple(int(body) for body in obstacles if int(body) != arm.body_id)
        self.attached = attached
        self.clearance = float(clearance)
        self.threshold = float(clearance - touch_tolerance)
        self.self_pairs = PANDA_SELF_COLLISION_PAIRS if self_collision else ()
        self.self_links = sorted({link for pair in self.self_pairs for link in pair})
        row = {link: i for i, link in enumerate(self.self_links)}
        self._pair_a = np.array([row[a] for a, _ in self.self_pairs], dtype=int)
        self._pair_b = np.array([row[b] for _, b in self.self_pairs], dtype=int)
        self.tilt_limit = float(tilt_limit)
        self.n_checks = 0
        client = arm.client_id
        # Moving links (the fixed base link -1 is never a fault against an obstacle).
        self._arm_links = tuple(range(pybullet.getNumJoints(arm.body_id, physicsClientId=client)))
        self._not_hand = tuple(i for i, link in enumerate(self._arm_links)
                               if link not in PANDA_HAND_LINKS)
        self._base_box: Box = pybullet.getAABB(arm.body_id, -1, physicsClientId=client)
        # Boxes of rigid obstacles (None: a body with moving joints, always queried).
        self._boxes = {body: _RigidBox.of(body, client) for body in self.obstacles}
        self._held_box = (None if attached is None
                          else _RigidBox.of(attached.body_id, client))
        # Boxes are grown by the query distance, plus a margin for pybullet's rounding.
        self._margin = self.clearance + 1e-3

    def __call__(self, q: np.ndarray) -> bool:
        return self.is_valid(q)

    def is_valid(self, q: np.ndarray) -> bool:
        """Move the arm (and attached body) to ``q`` and check every constraint."""
        self.n_checks += 1
        self.arm.set_configuration(q)
        client = self.arm.client_id
        robot = self.arm.body_id
        if self.attached is not None:
            tool_pose = self.arm.end_effector_pose() @ self.attached.grasp
            if self.attached.carries_contents and not within_tilt(tool_pose, self.tilt_limit):
                return False
            position, quaternion = tool_pose.as_tuples()
            pybullet.resetBasePositionAndOrientation(
                self.attached.body_id, position, quaternion, physicsClientId=client
            )
        arm_boxes: list[Box] = [pybullet.getAABB(robot, link, physicsClientId=client)
                                for link in self._arm_links]
        for obstacle in self.obstacles:
            if not self._near(arm_boxes, obstacle):
                continue
            points = pybullet.getClosestPoints(
                robot, obstacle, self.clearance, physicsClientId=client
            )
            # The fixed base link (-1) cannot move: resting on a stand or table is not a fault.
            if any(p[3] != -1 and p[8] < self.threshold for p in points):
                return False
        if self.attached is not None and not self._attached_free(arm_boxes):
            return False
        return self._self_collision_free(arm_boxes)

    def _near(self, boxes: Sequence[Box], obstacle: int) -> bool:
        """Can any of ``boxes`` be within the clearance of ``obstacle``?"""
        rigid = self._boxes[obstacle]
        if rigid is None:
            return True
        other = rigid.box()
        return any(_overlap(box, other, self._margin) for box in boxes)

    def _self_collision_free(self, arm_boxes: Sequence[Box]) -> bool:
        if not self.self_pairs:
            return True
        client = self.arm.client_id
        robot = self.arm.body_id
        # Bounding boxes first: most pairs are far apart, and an AABB query is ~1 µs.
        boxes = np.array(
            [arm_boxes[link] if 0 <= link < len(arm_boxes)
             else pybullet.getAABB(robot, link, physicsClientId=client)
             for link in self.self_links]
        )
        low_a, high_a = boxes[self._pair_a, 0], boxes[self._pair_a, 1]
        low_b, high_b = boxes[self._pair_b, 0], boxes[self._pair_b, 1]
        overlapping = np.all((low_a <= high_b) & (low_b <= high_a), axis=1)
        for pair_index in np.flatnonzero(overlapping):
            link_a, link_b = self.self_pairs[pair_index]
            points = pybullet.getClosestPoints(
                robot, robot, 0.0, linkIndexA=link_a, linkIndexB=link_b, physicsClientId=client
            )
            if any(p[8] < -1e-4 for p in points):
                return False
        return True

    def _attached_free(self, arm_boxes: Sequence[Box]) -> bool:
        assert self.attached is not None
        client = self.arm.client_id
        body = self.attached.body_id
        held = None if self._held_box is None else [self._held_box.box()]
        for obstacle in self.obstacles:
            if obstacle == body or (held is not None and not self._near(held, obstacle)):
                continue
            points = pybullet.getClosestPoints(
                body, obstacle, self.clearance, physicsClientId=client
            )
            if any(p[8] < self.threshold for p in points):
                return False
        # The hand and fingers hold it; no other link (the fixed base included) may touch it.
        if held is not None and not any(
                _overlap(box, held[0], 1e-3)
                for box in (self._base_box, *(arm_boxes[i] for i in self._not_hand))):
            return True
        points = pybullet.getClosestPoints(body, self.arm.body_id, 0.0, physicsClientId=client)
        return not any(p[4] not in PANDA_HAND_LINKS and p[8] < -1e-3 for p in points)


def within_tilt(pose: Pose, limit: float = CARRY_TILT_LIMIT) -> bool:
    """True when the pose's |roll| and |pitch| are both at most ``limit`` radians."""
    roll, pitch = tilt_roll_pitch(pose)
    return abs(roll) <= limit and abs(pitch) <= limit


def sample_self_collision_pairs(
    arm: PandaArm, rng: np.random.Generator, n_samples: int
) -> set[tuple[int, int]]:
    """Non-adjacent link pairs seen in contact over ``n_samples`` random configurations.

    Adjacent pairs are those in contact at the arm's home configuration. Used to derive
    and test :data:`PANDA_SELF_COLLISION_PAIRS`; leaves the arm at the last sample.
    """
    client = arm.client_id
    robot = arm.body_id

    def touching() -> set[tuple[int, int]]:
        points = pybullet.getClosestPoints(robot, robot, 0.0, physicsClientId=client)
        return {(min(p[3], p[4]), max(p[3], p[4])) for p in points if p[3] != p[4] and p[8] < -1e-4}

    arm.set_configuration(np.asarray(PANDA_HOME))
    adjacent = touching()
    seen: set[tuple[int, int]] = set()
    for _ in range(n_samples):
        arm.set_configuration(arm.sample_configuration(rng))
        seen |= touching() - adjacent
    return seen


def attach_fixed_constraint(arm: PandaArm, body_id: int, grasp: Pose) -> int:
    """Rigidly attach ``body_id`` to the Panda hand with a pybullet fixed constraint.

    For simulated execution (the paper's rigid attachment while grasping). The body is
    first placed at ``EE pose @ grasp``; the constraint joins it to the hand link (the grasp
    target link has no mass), expressed in the hand's centre-of-mass frame as pybullet
    expects. Returns the constraint id (``pybullet.removeConstraint`` releases it).
    """
    client = arm.client_id
    tool_pose = arm.end_effector_pose() @ grasp
    position, quaternion = tool_pose.as_tuples()
    pybullet.resetBasePositionAndOrientation(body_id, position, quaternion, physicsClientId=client)
    hand_state = pybullet.getLinkState(
        arm.body_id, PANDA_HAND_LINK, computeForwardKinematics=True, physicsClientId=client
    )
    hand_com = Pose(np.asarray(hand_state[0]), np.asarray(hand_state[1]))
    body_com_offset = pybullet.getDynamicsInfo(body_id, -1, physicsClientId=client)[3:5]
    body_com = tool_pose @ Pose(np.asarray(body_com_offset[0]), np.asarray(body_com_offset[1]))
    in_hand = hand_com.inverse() @ body_com
    parent_position, parent_quaternion = in_hand.as_tuples()
    return pybullet.createConstraint(
        arm.body_id,
        PANDA_HAND_LINK,
        body_id,
        -1,
        pybullet.JOINT_FIXED,
        jointAxis=(0.0, 0.0, 0.0),
        parentFramePosition=parent_position,
        childFramePosition=(0.0, 0.0, 0.0),
        parentFrameOrientation=parent_quaternion,
        childFrameOrientation=(0.0, 0.0, 0.0, 1.0),
        physicsClientId=client,
    )
