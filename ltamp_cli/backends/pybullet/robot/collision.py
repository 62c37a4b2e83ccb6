"""Collision checking of a Panda configuration with ``getClosestPoints``.

A check moves the arm kinematically to ``q``, places the attached (grasped) body at
``EE pose @ grasp`` and queries pybullet for closest points, cheapest tests first:

1. the attached body's tilt (|roll|, |pitch| ≤ limit) when it carries contents;
2. arm (without its fixed base link) against each obstacle body;
3. attached body against each obstacle and against the arm links other than the hand;
4. arm self-collision over :data:`PANDA_SELF_COLLISION_PAIRS`.

The attachment is *kinematic* (the body is re-posed at every check); during simulated
execution use :func:`attach_fixed_constraint` for a rigid pybullet constraint instead.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

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
        for obstacle in self.obstacles:
            points = pybullet.getClosestPoints(
                robot, obstacle, self.clearance, physicsClientId=client
            )
            # The fixed base link (-1) cannot move: resting on a stand or table is not a fault.
            if any(p[3] != -1 and p[8] < self.threshold for p in points):
                return False
        if self.attached is not None and not self._attached_free():
            return False
        return self._self_collision_free()

    def _self_collision_free(self) -> bool:
        if not self.self_pairs:
            return True
        client = self.arm.client_id
        robot = self.arm.body_id
        # Bounding boxes first: most pairs are far apart, and an AABB query is ~1 µs.
        boxes = np.array(
            [pybullet.getAABB(robot, link, physicsClientId=client) for link in self.self_links]
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

    def _attached_free(self) -> bool:
        assert self.attached is not None
        client = self.arm.client_id
        body = self.attached.body_id
        for obstacle in self.obstacles:
            if obstacle == body:
                continue
            points = pybullet.getClosestPoints(
                body, obstacle, self.clearance, physicsClientId=client
            )
            if any(p[8] < self.threshold for p in points):
                return False
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
