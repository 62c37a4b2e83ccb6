"""A Panda in the loop of a Kitchen3D trial: the tool is grasped and carried by the arm.

:class:`RobotTrialPhysics` implements :class:`~ltamp_cli.backends.skills3d.physics.TrialPhysics`
like :class:`~.physics.BulletTrialPhysics`, except that the *tool* is not moved kinematically:

1. When the tool body is added (:meth:`RobotTrialPhysics.add_body` with role ``"tool"``), a
   fixed-base Panda is loaded on the table ``settings.base_distance`` m from the tool's start
   pose along ``-y`` (facing ``+y``, across the skill's ``x``-``z`` plane of motion; then at
   ``+y`` facing ``-y`` if that fails), a side grasp approaching along ``±y`` is chosen
   (:func:`~..robot.grasps.cylinder_side_grasps`: the pour's tilt about ``y`` is then a
   roll of the wrist), and the skill's whole tool path
   (``preview``, the untimed waypoints) is solved by :func:`~..robot.cartesian.follow_tool_path`
   (verified IK, joint continuity, collision checks against the table, the bowl and the held
   tool). No solution: :class:`RobotFailure` ``"reach"``; a colliding one: ``"collision"``;
   no grasp narrower than the gripper: ``"grasp"``. Failing here costs no bead simulation.
2. The tool is held by a fixed constraint from the hand whose force is limited to
   ``settings.grasp_force`` newtons, so a heavy or shaken tool can slip out of the grasp.
3. :meth:`follow` drives the joints by position control along the solved configurations,
   timed by a rest-to-rest trapezoid over the path's joint-space length
   (:func:`~ltamp_cli.motion.timing.trapezoid_fraction`: every joint's speed stays below
   ``joint_speed`` rad/s); :meth:`hold` keeps commanding the current configuration.
4. After every simulated step the trial fails with :class:`RobotFailure` when the arm (any
   link but its fixed base) touches the table or the bowl, a link other than the hand touches
   the tool (``"collision"``), or the tool is more than ``slip_position_m`` /
   ``slip_angle_rad`` from where the grasp should hold it (``"slip"``).

The backend turns a :class:`RobotFailure` into the skill's failure score (a valid trial:
the control was executed and failed). Units: metres, radians, seconds, newtons.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pybullet as p

from ltamp_cli.backends.kitchenware_geometry import KitchenwareGeometry
from ltamp_cli.backends.protocol import TrialResult
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial, KitchenwareBody
from ltamp_cli.backends.pybullet.paths import PosePath
from ltamp_cli.backends.pybullet.robot.arm import (
    PANDA_HAND_LINK,
    PANDA_HAND_LINKS,
    PandaArm,
)
from ltamp_cli.backends.pybullet.robot.cartesian import CartesianConfig, follow_tool_path
from ltamp_cli.backends.pybullet.robot.collision import ArmCollisionChecker, AttachedBody
from ltamp_cli.backends.pybullet.robot.grasps import MAX_GRASP_WIDTH, Grasp, cylinder_side_grasps
from ltamp_cli.backends.pybullet.robot.pose import Pose, rotation_distance
from ltamp_cli.backends.pybullet.skills.physics import BulletTrialPhysics
from ltamp_cli.backends.skills3d.physics import IDENTITY_QUAT, BodyRole, SimBody, StepCallback
from ltamp_cli.motion.timing import trapezoid_duration, trapezoid_fraction

#: Values of the ``robot`` trial setting: ``none`` (free-floating tool) or ``panda``.
ROBOTS = ("none", "panda")
#: Why a robot trial failed (``info["reason"]``).
FAILURE_REASONS = ("reach", "collision", "slip", "grasp")


class RobotFailure(Exception):
    """The arm could not carry out the skill: ``reason`` in :data:`FAILURE_REASONS`."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(f"{reason}: {detail}")
        self.reason = reason
        self.detail = detail

    def result(self, failure_score: float) -> TrialResult:
        """The trial this failure makes: ``failure_score``, valid (the control was run)."""
        return TrialResult(failure_score, True, {"reason": self.reason, "robot": "panda",
                                                 "robot_detail": self.detail})


@dataclass(frozen=True)
class RobotSettings:
    """How the Panda holds and moves the tool.

    ``grasp_force`` (N): largest force of the grasp constraint (the tool slips beyond it).
    ``base_distance`` (m): horizontal distance from the tool's start position to the arm's
    base; ``base_bearings``: where the base stands around the tool's start (radians about
    ``z`` from ``+x``: ``-π/2`` at ``-y``, ``0`` at ``+x``), tried in turn until the path
    is solved. ``grasp_heights``: fractions of the cup's
    height tried for the side grasp, the first whose outer diameter fits the gripper wins.
    ``joint_speed`` (rad/s) and
    ``joint_acceleration`` (rad/s²): limits of the trapezoidal timing. ``position_gain``:
    PyBullet's joint position-control gain. ``slip_position_m`` / ``slip_angle_rad``: how far
    the tool may drift from the grasp before the trial counts as slipped.
    ``contact_tolerance_m``: penetration depth an arm contact needs to count (0: any
    touch). ``plan_collisions``: check the solved path for collisions before simulating
    (``False``: only the contacts met while simulating fail the trial).
    """

    grasp_force: float = 200.0
    base_distance: float = 0.5
    base_bearings: tuple[float, ...] = (-np.pi / 2, np.pi / 2)
    grasp_heights: tuple[float, ...] = (0.45, 0.3, 0.15)
    joint_speed: float = 2.0
    joint_acceleration: float = 8.0
    position_gain: float = 0.3
    slip_position_m: float = 0.02
    slip_angle_rad: float = 0.2
    contact_tolerance_m: float = 0.0
    plan_collisions: bool = True
    cartesian: CartesianConfig = field(default_factory=lambda: CartesianConfig(path_restarts=3))

    def __post_init__(self) -> None:
        if min(self.grasp_force, self.base_distance, self.joint_speed,
               self.joint_acceleration, self.position_gain, self.slip_position_m,
               self.slip_angle_rad) <= 0:
            raise ValueError("robot settings must be positive")
        if self.contact_tolerance_m < 0:
            raise ValueError("contact_tolerance_m must be >= 0")
        if not self.grasp_heights or not all(0.0 < h < 1.0 for h in self.grasp_heights):
            raise ValueError("grasp_heights must be fractions in (0, 1)")


def cup_grasps(geometry: KitchenwareGeometry, heights: Sequence[float]) -> tuple[Grasp, ...]:
    """Side grasps of a vessel approaching along ``±x`` and ``±y`` (hand upright and
    flipped), at the
    first fraction of ``heights`` where the outer diameter fits the gripper; empty if none."""
    dims = geometry.vessel
    if dims is None:
        raise RobotFailure("grasp", f"a {geometry.kind} has no side grasp")
    for fraction in heights:
        radius = float(dims.outer_radius_at(dims.height * fraction))
        if 2.0 * radius > MAX_GRASP_WIDTH - 0.002:
            continue
        grasps = cylinder_side_grasps(radius, dims.height, base_z=0.0, grasp_height=fraction,
                                      n_yaw=4)
        return grasps
    return ()


def timed_configurations(configurations: np.ndarray, speed: float, acceleration: float,
                         dt: float) -> np.ndarray:
    """Joint targets ``(m, 7)`` one step ``dt`` apart along ``configurations`` ``(n, 7)``.

    The path parameter is the joint-space length (the largest joint change, summed over
    the segments), traversed rest to rest with a trapezoidal profile: no joint exceeds
    ``speed`` rad/s, and the parameter's acceleration stays below ``acceleration`` rad/s².
    The path does not stop at its (dense, nearly collinear) waypoints. The last row is
    ``configurations[-1]``.
    """
    q = np.asarray(configurations, dtype=float)
    lengths = np.abs(np.diff(q, axis=0)).max(axis=1) if len(q) > 1 else np.zeros(0)
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    total = float(arc[-1])
    if total <= 1e-12:
        return q[-1:].copy()
    duration = trapezoid_duration(total, speed, acceleration)
    steps = max(1, int(np.ceil(duration / dt - 1e-9)))
    times = np.arange(1, steps + 1) * duration / steps  # stretched to whole steps
    s = trapezoid_fraction(times, total, speed, acceleration) * total
    s[-1] = total
    return np.stack([np.interp(s, arc, q[:, j]) for j in range(q.shape[1])], axis=1)


@dataclass(frozen=True)
class ArmPlan:
    """A solved carry: the arm's base pose, the grasp, and configurations ``(n, 7)``."""

    base: Pose
    grasp: Grasp
    configurations: np.ndarray


@dataclass(eq=False)
class RobotState:
    """What one robot trial has set up: the arm, its plan, the held tool, the bodies the arm
    must not touch, and the joint targets ``(7,)`` commanded last."""

    arm: PandaArm | None = None
    plan: ArmPlan | None = None
    tool: KitchenwareBody | None = None
    obstacles: list[int] = field(default_factory=list)
    command: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class RobotTrialPhysics(BulletTrialPhysics):
    """Trial physics with the tool in a Panda's hand (see the module docstring).

    ``preview`` is the skill's untimed tool path (the same poses :meth:`follow` will be
    given, before timing); ``seed`` seeds the IK restarts. One instance runs one trial.
    """

    preview: PosePath | None = None
    settings: RobotSettings = field(default_factory=RobotSettings)
    seed: int = 0
    state: RobotState = field(default_factory=RobotState, init=False)

    def reset(self) -> None:
        super().reset()
        self.state.arm = self.state.plan = self.state.tool = self.state.command = None
        self.state.obstacles = [self.world.table]

    def add_body(
        self,
        geometry: KitchenwareGeometry,
        material: BodyMaterial,
        role: BodyRole,
        position: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
        quaternion: Sequence[float] | np.ndarray = IDENTITY_QUAT,
    ) -> KitchenwareBody:
        """As :class:`BulletTrialPhysics`; a ``"tool"`` body is then grasped by the Panda
        (raises :class:`RobotFailure` when the preview path cannot be carried out)."""
        body = super().add_body(geometry, material, role, position, quaternion)
        if role == "fixed":
            self.state.obstacles.append(body.body)
        elif role == "tool":
            if self.state.tool is not None:
                raise ValueError("the Panda holds one tool per trial")
            self.state.tool = body
            self._grasp(body, Pose(np.asarray(position), np.asarray(quaternion)))
        return body

    # Planning ----------------------------------------------------------------------------

    def _grasp(self, tool: KitchenwareBody, start: Pose) -> None:
        if self.preview is None:
            raise ValueError("a robot trial needs the tool's path (preview) before the tool")
        client = self.world.client
        grasps = cup_grasps(tool.geometry, self.settings.grasp_heights)
        if not grasps:
            raise RobotFailure("grasp", "the cup is wider than the gripper at every grasp height")
        poses = [Pose(position, quaternion) for position, quaternion
                 in zip(self.preview.positions, self.preview.quaternions, strict=True)]
        rng = np.random.default_rng(self.seed)
        arm: PandaArm | None = None
        plan = None
        reasons = []
        for bearing in self.settings.base_bearings:
            # The arm stands base_distance from the tool's start at this bearing (radians
            # about z from +x), facing it; the palm approaches the tool towards the base's
            # opposite side.
            towards = np.array([np.cos(bearing), np.sin(bearing), 0.0])
            base = Pose.from_euler(start.position * np.array([1.0, 1.0, 0.0])
                                   + self.settings.base_distance * towards,
                                   yaw=bearing + np.pi)
            if arm is None:
                arm = PandaArm(client, base)
                self.state.arm = arm
            else:
                position, quaternion = base.as_tuples()
                p.resetBasePositionAndOrientation(arm.body_id, position, quaternion,
                                                  physicsClientId=client)
                arm.base_pose = base
            for grasp in grasps:
                approach = grasp.tool_in_gripper.inverse().rotation()[:, 2]
                if float(approach @ -towards) < 0.999:
                    continue
                checker = ArmCollisionChecker(arm, self.state.obstacles,
                                              AttachedBody(tool.body, grasp.tool_in_gripper))
                found = follow_tool_path(
                    arm, poses, grasp.tool_in_gripper, rng,
                    is_valid=checker if self.settings.plan_collisions else None,
                    config=self.settings.cartesian)
                if found.success:
                    assert found.configurations is not None
                    plan = ArmPlan(base, grasp, found.configurations)
                    break
                reasons.append((found.failed_index or 0, found.status))
            if plan is not None:
                break
        assert arm is not None
        tool.set_pose(start.position, start.quaternion)
        if plan is None:
            index, status = max(reasons)
            reason = "collision" if status == "collision" else "reach"
            raise RobotFailure(reason, f"{status} at pose {index} of the densified tool path")
        self.state.plan = plan
        self._attach(arm, tool, plan)

    def _attach(self, arm: PandaArm, tool: KitchenwareBody, plan: ArmPlan) -> None:
        """Arm at the plan's first configuration, fingers at the cup, tool held by a
        force-limited fixed constraint from the hand (the hand does not collide with it)."""
        client = self.world.client
        first = plan.configurations[0]
        arm.set_configuration(first)
        arm.set_finger_opening(plan.grasp.width + 0.002)
        arm.command_gripper(plan.grasp.width + 0.002)
        self.state.command = first
        arm.command_configuration(first, position_gain=self.settings.position_gain)
        tool_pose = arm.end_effector_pose() @ plan.grasp.tool_in_gripper
        tool.set_pose(tool_pose.position, tool_pose.quaternion)
        for link in PANDA_HAND_LINKS:
            for piece in tool.links:
                p.setCollisionFilterPair(arm.body_id, tool.body, link, piece, 0,
                                         physicsClientId=client)
        hand = p.getLinkState(arm.body_id, PANDA_HAND_LINK, computeForwardKinematics=True,
                              physicsClientId=client)
        hand_com = Pose(np.asarray(hand[0]), np.asarray(hand[1]))
        com_position, com_quaternion = p.getBasePositionAndOrientation(
            tool.body, physicsClientId=client)
        in_hand = hand_com.inverse() @ Pose(np.asarray(com_position), np.asarray(com_quaternion))
        position, quaternion = in_hand.as_tuples()
        constraint = p.createConstraint(
            arm.body_id, PANDA_HAND_LINK, tool.body, -1, p.JOINT_FIXED, (0.0, 0.0, 0.0),
            parentFramePosition=position, childFramePosition=(0.0, 0.0, 0.0),
            parentFrameOrientation=quaternion, childFrameOrientation=(0.0, 0.0, 0.0, 1.0),
            physicsClientId=client)
        p.changeConstraint(constraint, maxForce=self.settings.grasp_force,
                           physicsClientId=client)

    # Execution ---------------------------------------------------------------------------

    def follow(
        self, tool: SimBody, path: PosePath, on_step: StepCallback | None = None,
        step_offset: int = 0,
    ) -> int:
        """Drive the arm along the planned configurations (position control, trapezoidal
        timing); ``path`` must end where the preview ends."""
        arm, plan = self._holding(tool)
        if self.preview is not None and np.linalg.norm(
                path.positions[-1] - self.preview.positions[-1]) > 1e-6:
            raise ValueError("the robot follows the tool path it planned (the preview)")
        targets = timed_configurations(plan.configurations, self.settings.joint_speed,
                                       self.settings.joint_acceleration, self.time_step)

        def command(i: int) -> None:
            self.state.command = targets[i]
            arm.command_configuration(targets[i], position_gain=self.settings.position_gain)

        return self._run(len(targets), command, on_step, step_offset)

    def hold(
        self, tool: SimBody, position: np.ndarray, quaternion: np.ndarray, steps: int,
        on_step: StepCallback | None = None, step_offset: int = 0,
    ) -> int:
        """Keep commanding the arm's last target for ``steps`` steps (the tool stays where
        the arm holds it; ``position``/``quaternion`` are where the skill expects it)."""
        arm, _ = self._holding(tool)
        assert self.state.command is not None
        target = self.state.command
        return self._run(steps, lambda _: arm.command_configuration(
            target, position_gain=self.settings.position_gain), on_step, step_offset)

    def _holding(self, tool: SimBody) -> tuple[PandaArm, ArmPlan]:
        arm, plan = self.state.arm, self.state.plan
        if arm is None or plan is None or tool is not self.state.tool:
            raise ValueError("the robot moves only the tool it grasped")
        return arm, plan

    def _run(self, count: int, command: Callable[[int], None], on_step: StepCallback | None,
             step_offset: int) -> int:
        """Step ``count`` times, ``command(i)`` before step ``i``, then ``on_step`` and the
        failure checks after it."""
        def checked(i: int) -> None:
            if on_step is not None:
                on_step(step_offset + i)
            self._check(step_offset + i)

        return self.run_steps(count, command, checked, 0)

    def _check(self, step: int) -> None:
        """Raise :class:`RobotFailure` on an arm collision or a slipped tool."""
        arm, plan, tool = self.state.arm, self.state.plan, self.state.tool
        assert arm is not None and plan is not None and tool is not None
        client, robot = self.world.client, arm.body_id
        depth = -self.settings.contact_tolerance_m
        for obstacle in self.state.obstacles:
            for contact in p.getContactPoints(robot, obstacle, physicsClientId=client):
                if contact[3] != -1 and contact[8] <= depth:
                    raise RobotFailure("collision", f"arm link {contact[3]} hit body "
                                       f"{obstacle} at step {step}")
        for contact in p.getContactPoints(robot, tool.body, physicsClientId=client):
            if contact[3] not in PANDA_HAND_LINKS and contact[8] <= depth:
                raise RobotFailure("collision", f"arm link {contact[3]} hit the tool at "
                                   f"step {step}")
        held = arm.end_effector_pose() @ plan.grasp.tool_in_gripper
        position, quaternion = tool.pose()
        actual = Pose(position, quaternion)
        drift = float(np.linalg.norm(actual.position - held.position))
        turn = rotation_distance(actual, held)
        if drift > self.settings.slip_position_m or turn > self.settings.slip_angle_rad:
            raise RobotFailure("slip", f"tool {drift:.3f} m / {turn:.2f} rad out of the grasp "
                               f"at step {step}")
