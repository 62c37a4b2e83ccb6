"""A free-flying two-finger gripper (x, y, θ, opening) that grasps by contact.

The palm and the two fingers are kinematic bodies: before every physics step the gripper
sets their velocities so that they reach exactly the commanded pose at the end of the step
(no drift, and contacts with particles see real velocities). A grasped object becomes
kinematic too and is carried rigidly; releasing makes it dynamic again with the gripper's
velocity. The gripper frame's origin is the grasp point, midway between the finger tips'
inner faces, one ``tip`` above the finger ends; fingers hang down (−y) from the palm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from Box2D import b2

from ltamp_cli.backends.box2d.geometry import Box
from ltamp_cli.backends.box2d.kitchenware import Pose
from ltamp_cli.backends.box2d.world import Kitchen


@dataclass(frozen=True)
class GripperSpec:
    """Gripper dimensions (world units).

    The gripper pinches bars (cup handles, spoon handles, stirrers) from above, so its
    opening is small and its palm narrow; fingers are long enough to reach a handle's foot.
    """

    finger_length: float = 5.5
    finger_width: float = 0.3
    palm_thickness: float = 0.4
    max_opening: float = 0.8
    tip: float = 0.3

    def finger_center(self, side: int, opening: float) -> tuple[float, float]:
        """Centre of the left (``side=-1``) or right (``+1``) finger in the gripper frame."""
        return (side * (opening / 2 + self.finger_width / 2), self.finger_length / 2 - self.tip)

    def finger_box(self) -> Box:
        return Box(0.0, 0.0, self.finger_width / 2, self.finger_length / 2)

    def palm_box(self) -> Box:
        return Box(
            0.0,
            self.finger_length - self.tip + self.palm_thickness / 2,
            self.max_opening / 2 + self.finger_width,
            self.palm_thickness / 2,
        )

    def boxes(self, opening: float) -> tuple[Box, ...]:
        """Palm and fingers in the gripper frame at the given opening."""
        finger = self.finger_box()
        out = [self.palm_box()]
        for side in (-1, 1):
            cx, cy = self.finger_center(side, opening)
            out.append(Box(cx, cy, finger.hw, finger.hh))
        return tuple(out)


def compose(a: Pose, b: Pose) -> Pose:
    """Pose ``b`` given in frame ``a``, expressed in the world."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def relative(a: Pose, b: Pose) -> Pose:
    """Pose of ``b`` in frame ``a`` (inverse of :func:`compose`)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return (c * dx + s * dy, -s * dx + c * dy, b[2] - a[2])


def body_pose(body: b2.body) -> Pose:
    return (float(body.position[0]), float(body.position[1]), float(body.angle))


def touching(a: b2.body, b: b2.body) -> bool:
    """Whether two bodies are in contact (touching contact or overlapping shapes)."""
    for edge in a.contacts:
        if edge.other == b and edge.contact.touching:
            return True
    for fa in a.fixtures:
        for fb in b.fixtures:
            if b2.testOverlap(fa.shape, 0, fb.shape, 0, a.transform, b.transform):
                return True
    return False


class Gripper:
    """The robot. Command poses with :meth:`command`, or use the blocking motions."""

    def __init__(
        self,
        kitchen: Kitchen,
        pose: Pose,
        opening: float,
        spec: GripperSpec | None = None,
    ) -> None:
        self.kitchen = kitchen
        self.spec = spec or GripperSpec()
        self.pose: Pose = tuple(float(v) for v in pose)  # type: ignore[assignment]
        self.opening = float(opening)
        self._target: Pose = self.pose
        self._target_opening = self.opening
        self.held: b2.body | None = None
        self._held_rel: Pose = (0.0, 0.0, 0.0)
        #: Force-limited drive of a dynamically held body (see :meth:`hold_dynamically`).
        self._drive_joint: b2.joint | None = None
        world = kitchen.world
        color = (230, 190, 40)
        palm = self.spec.palm_box()
        self.palm = world.CreateKinematicBody(position=pose[:2], angle=pose[2])
        self.palm.CreatePolygonFixture(box=(palm.hw, palm.hh, (palm.cx, palm.cy), 0.0))
        self.palm.userData = {"name": "gripper", "color": color}
        finger = self.spec.finger_box()
        self.fingers: list[b2.body] = []
        for side in (-1, 1):
            x, y, a = compose(self.pose, (*self.spec.finger_center(side, opening), 0.0))
            body = world.CreateKinematicBody(position=(x, y), angle=a)
            body.CreatePolygonFixture(box=(finger.hw, finger.hh), friction=1.0)
            body.userData = {"name": "gripper", "color": color}
            self.fingers.append(body)
        kitchen.add_hook(self._drive)

    @property
    def bodies(self) -> list[b2.body]:
        return [self.palm, *self.fingers]

    # --- low level -----------------------------------------------------------------------
    def command(self, pose: Pose, opening: float | None = None) -> None:
        """Pose (and opening) to reach at the end of the next physics step."""
        self._target = (float(pose[0]), float(pose[1]), float(pose[2]))
        if opening is not None:
            self._target_opening = float(np.clip(opening, 0.0, self.spec.max_opening))

    def _drive(self, dt: float) -> None:
        pose, opening = self._target, self._target_opening
        targets = [(self.palm, pose)]
        for side, body in zip((-1, 1), self.fingers, strict=True):
            targets.append((body, compose(pose, (*self.spec.finger_center(side, opening), 0.0))))
        if self.held is not None and self._drive_joint is None:
            targets.append((self.held, compose(pose, self._held_rel)))
        for body, (x, y, a) in targets:
            body.linearVelocity = ((x - body.position[0]) / dt, (y - body.position[1]) / dt)
            body.angularVelocity = (a - body.angle) / dt
        self.pose, self.opening = pose, opening

    # --- grasping ------------------------------------------------------------------------
    def grasp(self, body: b2.body) -> bool:
        """Attach ``body`` if both fingers touch it; returns whether it was grasped."""
        if not all(touching(finger, body) for finger in self.fingers):
            return False
        self._held_rel = relative(self.pose, body_pose(body))
        body.type = b2.kinematicBody
        self.held = body
        return True

    def hold_dynamically(self, max_force: float, max_torque: float) -> None:
        """Make the held body dynamic, driven to its grasp pose by a motor joint on the palm
        whose force (units) and torque are bounded: contacts can then slow or stop it, as
        they would a real grasp, instead of an unstoppable kinematic body crushing what it
        meets. The fingers stop colliding with it (they would otherwise push it with
        infinite force). :meth:`hold_rigidly` undoes it."""
        body = self.held
        if body is None or self._drive_joint is not None:
            return
        body.type = b2.dynamicBody
        body.awake = True
        for part in (body, *self.bodies):
            for fixture in part.fixtures:
                data = fixture.filterData
                data.groupIndex = -1
                fixture.filterData = data
        self._drive_joint = self.kitchen.world.CreateMotorJoint(
            bodyA=self.palm, bodyB=body, maxForce=max_force, maxTorque=max_torque,
            correctionFactor=0.3, collideConnected=False)
        rel = relative(body_pose(self.palm), body_pose(body))
        self._drive_joint.linearOffset = (rel[0], rel[1])
        self._drive_joint.angularOffset = rel[2]

    def hold_rigidly(self) -> None:
        """Back to a kinematic hold at the body's current pose in the hand."""
        body = self.held
        if body is None or self._drive_joint is None:
            return
        self.kitchen.world.DestroyJoint(self._drive_joint)
        self._drive_joint = None
        for part in (body, *self.bodies):
            for fixture in part.fixtures:
                data = fixture.filterData
                data.groupIndex = 0
                fixture.filterData = data
        self._held_rel = relative(self.pose, body_pose(body))
        body.type = b2.kinematicBody

    def release(self, open_fingers: bool = True) -> b2.body | None:
        """Let go: the held body becomes dynamic again and keeps its current velocity.

        With ``open_fingers`` the fingers then open fully (stepping the world), since
        closed fingers would otherwise keep holding the body by friction.
        """
        self.hold_rigidly()
        body, self.held = self.held, None
        if body is not None:
            velocity, spin = b2.vec2(body.linearVelocity), body.angularVelocity
            body.type = b2.dynamicBody
            body.linearVelocity, body.angularVelocity = velocity, spin
            body.awake = True
        if open_fingers:
            self.move(self._target, opening=self.spec.max_opening)
        return body

    def close(self, speed: float = 2.0, max_time: float = 3.0) -> b2.body | None:
        """Close the fingers until both touch the same dynamic body, then grasp it."""
        step = speed * self.kitchen.config.dt
        for _ in range(int(max_time / self.kitchen.config.dt)):
            for candidate in self._touched_by_both():
                if self.grasp(candidate):
                    return candidate
            if self._target_opening <= 0.0:
                return None
            self.command(self._target, self._target_opening - step)
            self.kitchen.step()
        return None

    def _touched_by_both(self) -> list[b2.body]:
        sets = []
        for finger in self.fingers:
            sets.append(
                {
                    edge.other
                    for edge in finger.contacts
                    if edge.contact.touching and edge.other.type == b2.dynamicBody
                }
            )
        return [body for body in sets[0] & sets[1] if body.userData.get("name") != "particle"]

    # --- blocking motions ----------------------------------------------------------------
    def move(
        self,
        pose: Pose,
        *,
        speed: float = 4.0,
        angular_speed: float = 1.5,
        opening: float | None = None,
    ) -> None:
        """Move in a straight line in (x, y, θ) at the given speeds (units/s, rad/s)."""
        start, start_opening = self._target, self._target_opening
        goal_opening = start_opening if opening is None else opening
        duration = max(
            math.hypot(pose[0] - start[0], pose[1] - start[1]) / speed,
            abs(pose[2] - start[2]) / angular_speed,
            abs(goal_opening - start_opening) / speed,
        )
        n = max(1, math.ceil(duration / self.kitchen.config.dt - 1e-9))
        for k in range(1, n + 1):
            f = k / n
            self.command(
                tuple(s + f * (g - s) for s, g in zip(start, pose, strict=True)),  # type: ignore[arg-type]
                start_opening + f * (goal_opening - start_opening),
            )
            self.kitchen.step()

    def track(self, poses: np.ndarray) -> None:
        """Command one pose ``(x, y, θ)`` per physics step, rows of ``poses`` ``(m, 3)`` (a
        timed trajectory, e.g. from :func:`ltamp_cli.motion.timing.time_path`)."""
        for pose in np.asarray(poses, dtype=float):
            self.command((float(pose[0]), float(pose[1]), float(pose[2])))
            self.kitchen.step()

    def hold(self, seconds: float) -> None:
        """Stay still for ``seconds``."""
        self.command(self._target)
        self.kitchen.step(max(1, round(seconds / self.kitchen.config.dt)))
