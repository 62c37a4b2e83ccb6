"""Replaying kitchen3d plans in PyBullet and checking the goal in the simulated world.

The arm is driven kinematically along the planned joint paths (one configuration per
simulation step, at a bounded joint speed; a pour, scoop or stir moves its tool at the
skill's own speeds, as in the trials a learned skill's model learned from,
:data:`SKILL_TIMINGS`); a held object is rigidly carried at
``EE pose @ grasp`` with the velocity that reaches its next pose, so contacts push beads the
way the pour trials do (and is made heavy while held, so a bead pile cannot push it down
within a step); motions carrying contents start and stop each path segment at a bounded
acceleration. The fingers are kinematic too (held where they were set). Cups, blocks and
beads are dynamic: a released object falls and settles, beads slosh and pour under gravity.
Picks are closed-loop: they read where the object actually stands and re-solve the
approach when it is off its planned pose, then verify that both fingers are at the object
before carrying it; places verify where the object came to rest. The goal is checked from
bead positions and object poses, never from the plan.

Actions (the arm is the last argument; every path value carries its arm index, so two-arm
plans need nothing more): ``move-free``, ``move-holding``, ``pick``, ``place``, ``pour``,
``scoop`` (forward only: the spoon ends above the rim holding a spoonful), ``dump`` (like
``pour``: turn over, hold, turn back), ``stir`` (forward into the cup and circles, then back
out) and ``push`` (hand empty, fingers closed, forward only; the object must come to rest
within :data:`PUSH_TOLERANCE_M` of its target). Tools (spoons, stirrers) that are not held
stand pinned where they were placed (a rod on its tip would fall over).

Goal facts checked physically:

* ``(Contains c m)``: a poured material (it started in a container): at least
  :data:`CONTAINS_FRACTION` of the beads that started inside a container are in ``c``. A
  scooped material: ``c`` holds at least :data:`SCOOP_CONTAINS_FRACTION` of the last
  spoonful of ``m`` (beads in the spoon's head once the scoop had settled), and at least
  :data:`SCOOP_CONTAINS_MIN_BEADS` beads.
* ``(Stirred c)``: during some ``stir`` the stirrer's tip was inside ``c``'s containment
  prism for :data:`~.skills.stir.STIR_MIN_TIME_S` s while travelling
  :data:`~.skills.stir.STIR_MIN_TRAVEL_M` m inside it (the stir skill's rule).
* ``(On o r)``: ``o``'s base centre is in region ``r``; ``(Holding o)``: ``o`` is carried.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import pybullet as p
from scipy.spatial.transform import Rotation

from ltamp_cli.backends.execution import ExecutionReport
from ltamp_cli.backends.frames import GifTiming, action_caption, action_focus
from ltamp_cli.backends.pybullet.kitchenware import (
    BodyMaterial,
    KitchenwareBody,
    create_kitchenware,
    world_to_object,
)
from ltamp_cli.backends.pybullet.particles import (
    BeadSpec,
    bead_positions,
    contained_mask,
    count_lost,
    spawn_beads_in,
)
from ltamp_cli.backends.pybullet.paths import segment_steps
from ltamp_cli.backends.pybullet.render import Camera
from ltamp_cli.backends.pybullet.replay import (
    BeadGroup,
    ReplayFrame,
    ReplayRecorder,
    ReplayScene,
    bead_rgba,
)
from ltamp_cli.backends.pybullet.robot.arm import (
    PANDA_ARM_JOINTS,
    PANDA_FINGER_JOINTS,
    PANDA_HOME,
)
from ltamp_cli.backends.pybullet.robot.cartesian import follow_tool_path
from ltamp_cli.backends.pybullet.robot.pose import Pose, rotation_distance
from ltamp_cli.backends.pybullet.robot.scene import KitchenScene, build_kitchen_scene
from ltamp_cli.backends.pybullet.skills.stir import TipTracker
from ltamp_cli.backends.pybullet.tamp.grasping import object_grasps
from ltamp_cli.backends.pybullet.tamp.planning import pose_of
from ltamp_cli.backends.pybullet.tamp.scene import SceneSpec, scene_from_world
from ltamp_cli.backends.pybullet.tamp.skill_paths import (
    STIR_SPEED_M_S,
    fingers_across,
    push_finger_gap,
)
from ltamp_cli.backends.pybullet.tamp.values import ArmPath
from ltamp_cli.backends.pybullet.world import PhysicsWorld, WorldConfig, skill_world_config
from ltamp_cli.backends.skills3d.pour import POUR_SPEED_M_S, PourSettings
from ltamp_cli.backends.skills3d.scoop import ScoopSettings
from ltamp_cli.backends.skills3d.stir import STIR_ANGULAR_SPEED
from ltamp_cli.motion.timing import MotionLimits, time_path

#: Fraction of a material's beads that must end in a container for ``(Contains c m)``.
CONTAINS_FRACTION = 0.8
#: How far (m) a placed object may come to rest from its planned pose.
PLACE_TOLERANCE_M = 0.02
#: A pick needs both fingers within this distance (m) of the object.
FINGER_CONTACT_M = 0.01
#: A pushed object must come to rest this close (m) to its target pose.
PUSH_TOLERANCE_M = 0.03
#: ``(Contains c m)`` of a scooped material: this fraction of the last spoonful, and at
#: least this many beads, in ``c``.
SCOOP_CONTAINS_FRACTION = 0.5
SCOOP_CONTAINS_MIN_BEADS = 3
#: The skill whose trials' physics (solver iterations, contact breaking threshold:
#: :func:`~.world.skill_world_config`, the one place the trials take theirs from) each skill
#: action of a plan runs under (:meth:`Kitchen3DRun.skill_physics`); the world's own
#: settings are restored after. Other actions (transit, carries, picks, places, the dump)
#: keep the world's. E.g. the scoop steps at 50 solver iterations as its trials do (issue
#: #20: executed at 5, the under-converged bead contacts shed spoonfuls during the lift that
#: its model was trained to keep), and the push at Bullet's 2 cm threshold (the world's 4 mm,
#: made for fast bead piles, keeps one contact point per pair: a sliding base stands on one
#: corner, a different one each step, and push_to_reach seed 0 came to rest 0.032 m off
#: target, or 0.027 m, by luck of the plan).
ACTION_SKILLS: Mapping[str, str] = MappingProxyType({
    "pour": "pour", "scoop": "scoop", "stir": "stir", "push": "push"})
#: Joint motor force (N·m) holding a driven arm's joint velocities during a push step.
DRIVE_FORCE_N = 500.0
#: A pick looks at its object first: when the object stands more than this far (m) or
#: turned more than :data:`REPERCEIVE_RAD` from where the plan expected it, the approach is
#: re-solved relative to where it is (closed-loop pick); beyond :data:`REPERCEIVE_MAX_M`
#: the pick fails.
REPERCEIVE_M = 0.003
REPERCEIVE_RAD = 0.05
REPERCEIVE_MAX_M = 0.05
#: Up to this offset (m) and turn (rad) a pick whose shifted approach has no IK solution
#: keeps the planned approach, which the open fingers tolerate (pour_blocked seed 2: the cup
#: nudged 2 mm and turned 0.07 rad by the finger that picked the block beside it).
REPERCEIVE_OPEN_LOOP_M = 0.006
REPERCEIVE_OPEN_LOOP_RAD = 0.15
#: Kinds revolved about their own vertical (z) axis: a turn about that axis leaves the
#: object, and every grasp of it, as it was, so a pick ignores it. (push_to_reach seed 0:
#: the cup, untouched, spins ~0.3 rad on the table while the other arm pushes the bowl, and
#: re-solving the approach for that spin found no IK for one of its side grasps.)
REVOLVED_KINDS = ("cup", "bowl")
#: Object kinds that are tools: pinned where they stand while not held.
TOOL_KINDS = ("spoon", "stirrer")
#: A held object's mass is multiplied by this while it is carried. The carry is kinematic
#: (re-posed every step), but within a step the solver lets contacts move the light cup: a
#: pile of beads then pushed its base down each step and sank through it (pour_blocked
#: seed 1 lost 52 of 60 beads through the bottom during the carry, at any tilt).
HELD_MASS_FACTOR = 50.0


@dataclass(frozen=True)
class SkillTiming:
    """How a skill's trials move its tool: the tool frame's origin at ``speed`` m/s, its
    orientation at ``angular_speed`` rad/s; each path segment takes the longer of the two
    (:func:`~.paths.segment_steps`), with no stop at the waypoints."""

    speed: float
    angular_speed: float


#: The timing of every skill whose tool path the executor follows as the skill's own trials
#: move the tool, by path kind (:attr:`ArmPath.kind`): the learned pour and scoop at their
#: trials' speeds (:data:`~.skills3d.pour.POUR_SPEED_M_S` and the pour's turn rate,
#: :class:`~.skills3d.scoop.ScoopSettings`), the stir at the tip speed the kitchen's stir
#: uses as its ``speed`` control (:data:`~.tamp.skill_paths.STIR_SPEED_M_S`) and its
#: trials' turn rate. Other motions (transit, carries, picks, places, the engineered dump
#: and push) are joint-speed and acceleration limited (:meth:`Kitchen3DRun.follow`).
SKILL_TIMINGS: Mapping[str, SkillTiming] = MappingProxyType({
    "pour": SkillTiming(POUR_SPEED_M_S, PourSettings().angular_speed),
    "scoop": SkillTiming(ScoopSettings().speed, ScoopSettings().angular_speed),
    "stir": SkillTiming(STIR_SPEED_M_S, STIR_ANGULAR_SPEED),
})


class ActionFailed(RuntimeError):
    """An action could not be carried out physically (e.g. the fingers missed the object)."""


@dataclass(frozen=True)
class ExecutionSettings:
    """Joint speeds (rad/s) for transit, carrying contents, dumping a spoon and pushing (a
    pour, scoop or stir moves its tool at its skill's speeds, :data:`SKILL_TIMINGS`);
    settle/hold times (s)."""

    free_speed: float = 1.5
    carry_speed: float = 0.8
    dump_speed: float = 1.2
    push_speed: float = 0.4
    settle_s: float = 0.4
    pour_hold_s: float = 0.8
    render_every: int = 12
    #: Largest joint acceleration (rad/s²) of every executed motion: every segment of a
    #: path starts and ends at rest with a trapezoidal speed profile, as a real arm would
    #: (at constant joint speed a carry's corners jerked the cup at ~60 m/s²; with this
    #: limit the peaks were ~9 m/s²).
    acceleration: float = 2.0


def skill_timed_configurations(configurations: np.ndarray, tool_poses: Sequence[Pose],
                               speed: float, angular_speed: float, dt: float) -> np.ndarray:
    """Joint configurations ``(m, 7)`` one step ``dt`` (s) apart along ``configurations``
    ``(n, 7)``, whose tool poses are ``tool_poses`` (n): segment ``i`` takes the longer of
    the tool's shift / ``speed`` (m/s) and turn / ``angular_speed`` (rad/s), at least one
    step, interpolated linearly in joint space (the waypoints are dense). The first row is
    ``configurations[0]`` (the current position), the last ``configurations[-1]``."""
    q = np.asarray(configurations, dtype=float)
    if q.ndim != 2 or len(q) != len(tool_poses) or len(q) == 0:
        raise ValueError(f"{len(tool_poses)} tool poses for configurations of shape {q.shape}")
    if min(speed, angular_speed, dt) <= 0:
        raise ValueError("speed, angular_speed and dt must be positive")
    rows = [q[:1]]
    for i in range(len(q) - 1):
        shift = float(np.linalg.norm(tool_poses[i + 1].position - tool_poses[i].position))
        turn = rotation_distance(tool_poses[i], tool_poses[i + 1])
        steps = segment_steps(shift, turn, speed, angular_speed, dt)
        fractions = np.linspace(0.0, 1.0, steps + 1)[1:, None]
        rows.append(q[i] + fractions * (q[i + 1] - q[i]))
    return np.concatenate(rows, axis=0)


def _material(kind: str, rng: np.random.Generator, fixed: bool) -> BodyMaterial:
    friction = float(np.clip(rng.normal(0.5, 0.1), 0.2, 0.8))
    colours = {"cup": (0.9, 0.5, 0.2, 1.0), "bowl": (0.85, 0.85, 0.8, 1.0),
               "block": (0.3, 0.6, 0.3, 1.0), "faucet": (0.6, 0.6, 0.65, 1.0)}
    mass = 0.0 if fixed else {"cup": 0.15, "block": 0.2}.get(kind, 0.1)
    return BodyMaterial(mass=mass, lateral_friction=friction, restitution=0.1,
                        rgba=colours.get(kind, (0.7, 0.7, 0.7, 1.0)))


def _goal_atoms(formula: Any) -> list[tuple[str, tuple[str, ...]]]:
    from ltamp_cli.planner.pddl.syntax import And, Atom

    if isinstance(formula, Atom):
        return [(formula.predicate.lower(), tuple(a.lower() for a in formula.args))]
    if isinstance(formula, And):
        return [atom for part in formula.parts for atom in _goal_atoms(part)]
    raise ActionFailed("only conjunctions of facts can be checked physically")


def without_spin(actual: Pose, expected: Pose) -> Pose:
    """``actual`` (an object's pose) turned back about its own z axis to ``expected``'s
    spin: ``expected``'s orientation tilted by the least rotation that takes its z axis to
    ``actual``'s (for objects revolved about that axis, the same object pose)."""
    axis_expected = expected.rotation()[:, 2]
    axis_actual = actual.rotation()[:, 2]
    cross = np.cross(axis_expected, axis_actual)
    sine = float(np.linalg.norm(cross))
    tilt = (Rotation.identity() if sine < 1e-12 else Rotation.from_rotvec(
        cross / sine * math.atan2(sine, float(np.dot(axis_expected, axis_actual)))))
    orientation = tilt * Rotation.from_quat(expected.quaternion)
    return Pose(actual.position, orientation.as_quat())


class Kitchen3DRun:
    """One execution: the live PyBullet kitchen plus what the actions achieved."""

    #: Called after every step of :meth:`follow` while set (the stir's tip tracking).
    probe: Callable[[], None] | None = None
    #: Whether :meth:`follow` is driving the arm with joint velocities (a push).
    driving: bool = False

    def __init__(self, spec: SceneSpec, poses: dict[str, tuple[float, float]], seed: int,
                 settings: ExecutionSettings, recorder_camera: Camera | None) -> None:
        self.spec = spec
        self.settings = settings
        self.rng = np.random.default_rng(seed)
        self.world = PhysicsWorld(WorldConfig())
        self.scene: KitchenScene = build_kitchen_scene(self.world.client, spec.n_arms, spec.table)
        self.table_z = float(self.scene.table.height)
        self.recorder: ReplayRecorder | None = None
        self.steps = 0
        self.log: list[dict[str, Any]] = []
        self.bodies: dict[str, KitchenwareBody] = {}
        for name, obj in spec.objects.items():
            xy = obj.at if obj.fixed else poses.get(name)
            if xy is None:
                raise ActionFailed(f"object {name!r} has no initial AtPose")
            pose = pose_of(xy, self.table_z)
            self.bodies[name] = create_kitchenware(
                self.world.client, obj.geometry(), pose.position, pose.quaternion,
                _material(obj.kind, self.rng, obj.fixed))
        # Beads per material, and which container each material started in.
        self.beads: dict[str, np.ndarray] = {}
        for name, obj in spec.objects.items():
            if obj.contents is None:
                continue
            beads = BeadSpec(count=obj.contents.beads, radius=0.006,
                             lateral_friction=float(np.clip(self.rng.normal(0.5, 0.1), 0.2, 0.8)),
                             restitution=float(np.clip(self.rng.normal(0.7, 0.1), 0.4, 0.9)))
            self.beads[obj.contents.material] = spawn_beads_in(self.bodies[name], beads, self.rng)
        for arm in self.scene.arms:
            arm.set_configuration(np.asarray(PANDA_HOME))
            # Fingers are kinematic too: no motors fight the resets.
            p.setJointMotorControlArray(arm.body_id, PANDA_FINGER_JOINTS, p.VELOCITY_CONTROL,
                                        forces=[0.0, 0.0], physicsClientId=self.world.client)
        self.held: dict[int, tuple[str, Pose]] = {}
        self._init_records()
        self.pinned = {name: self.bodies[name].pose() for name in self._tools()}
        if recorder_camera is not None:
            # Record states (cheap) and render only what the GIF keeps, afterwards.
            self.recorder = ReplayRecorder(
                self._replay_scene(), self._snapshot, settings.render_every, recorder_camera,
                seconds_per_step=self.world.config.time_step, follow=True)
            self.recorder.caption = "initial state"
        self.step_n(self.world.steps_for(settings.settle_s))
        self.initial_counts = self.counts()

    def _init_records(self) -> None:
        """State beyond the bodies: tools pinned at rest (name -> pose), every arm's last
        commanded configuration, the last spoonful of each scooped material (beads) and
        each cup's stir records."""
        self.pinned: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self.commanded: dict[int, np.ndarray] = {
            i: arm.get_configuration() for i, arm in enumerate(self.scene.arms)}
        self.spoonfuls: dict[str, int] = {}
        self.stirs: dict[str, list[dict[str, Any]]] = {}

    def _replay_scene(self) -> ReplayScene:
        """What a replay of this run draws: arms, table, kitchenware and beads."""
        return ReplayScene(
            self.spec.n_arms, self.spec.table,
            {name: body.geometry for name, body in self.bodies.items()},
            {material: BeadGroup(len(ids), 0.006, bead_rgba(material, index))
             for index, (material, ids) in enumerate(self.beads.items())})

    def _snapshot(self) -> ReplayFrame:
        """Every actor's state now (arms, kitchenware poses, bead centres)."""
        return ReplayFrame(
            tuple((arm.get_configuration(), arm.finger_opening()) for arm in self.scene.arms),
            {name: body.pose() for name, body in self.bodies.items()},
            {material: bead_positions(self.world.client, ids)
             for material, ids in self.beads.items()})

    def film(self, caption: str, focus: str | None) -> None:
        """Caption the frames recorded from now on, with a top view into the object named
        ``focus`` (``None``: no inset)."""
        if self.recorder is not None:
            self.recorder.caption = caption
            self.recorder.focus = focus

    def _tools(self) -> list[str]:
        return [n for n, o in self.spec.objects.items() if o.kind in TOOL_KINDS and not o.fixed]

    def close(self) -> None:
        self.world.close()

    # Simulation --------------------------------------------------------------------------

    def skill_physics(self, action: str) -> AbstractContextManager[None]:
        """Step with the physics of the trials of ``action``'s skill inside the block
        (:data:`ACTION_SKILLS`; their world's solver iterations and contact breaking
        threshold, :func:`~.world.skill_world_config`), so a learned skill executes in the
        physics its model was trained in. Raises ``KeyError`` for an action of no skill."""
        return self.world.skill_physics(skill_world_config(ACTION_SKILLS[action]))

    def _step(self) -> None:
        for name, (position, quaternion) in self.pinned.items():
            self.bodies[name].set_pose(position, quaternion)
        # The fingers are kinematic like the arm (set between steps, no motors): undo what a
        # step did to them. Left free, an open finger slid shut during a descent and knocked
        # the block it was about to grasp (pour_blocked seed 0's re-pick).
        fingers = [(arm, [s[0] for s in p.getJointStates(arm.body_id, PANDA_FINGER_JOINTS,
                                                          physicsClientId=self.world.client)])
                   for arm in self.scene.arms]
        self.world.step()
        for arm, positions in fingers:
            for joint, position in zip(PANDA_FINGER_JOINTS, positions, strict=True):
                p.resetJointState(arm.body_id, joint, position,
                                  physicsClientId=self.world.client)
        if self.recorder is not None:
            self.recorder(self.steps)
        self.steps += 1

    def _hold_arms(self, moving: int | None = None) -> None:
        """Re-apply every arm's last commanded configuration (but ``moving``'s): between
        resets gravity would make a resting arm sag (centimetres in a second), and the next
        reset would then yank whatever it holds."""
        for index, q in self.commanded.items():
            if index != moving:
                self.scene.arms[index].set_configuration(q)

    def step_n(self, n: int) -> None:
        for _ in range(n):
            self._hold_arms()
            for arm_index, (name, grasp) in self.held.items():
                self._carry(arm_index, name, grasp, None)
            self._step()

    def _carry(self, arm_index: int, name: str, grasp: Pose, nxt: Pose | None) -> None:
        tool = self.scene.arms[arm_index].end_effector_pose() @ grasp
        dt = self.world.config.time_step
        linear = np.zeros(3)
        angular = np.zeros(3)
        if nxt is not None:
            linear = (nxt.position - tool.position) / dt
            delta = Pose(np.zeros(3), nxt.quaternion) @ Pose(np.zeros(3), tool.quaternion).inverse()
            angle = 2.0 * math.acos(min(1.0, abs(float(delta.quaternion[3]))))
            axis = delta.quaternion[:3]
            norm = float(np.linalg.norm(axis))
            if norm > 1e-12:
                sign = 1.0 if delta.quaternion[3] >= 0 else -1.0
                angular = sign * axis / norm * angle / dt
        self.bodies[name].set_pose(tool.position, tool.quaternion, linear, angular)

    def follow(self, arm_index: int, configurations: np.ndarray, speed: float,
               drive: bool = False) -> None:
        """Drive the arm through ``configurations`` (n, 7) at ``speed`` rad/s (max joint),
        accelerating at most ``settings.acceleration`` rad/s² and stopping at every waypoint.

        ``drive`` (pushes): the links also get the joint velocities that reach the next
        configuration, so contacts see a moving hand; a merely teleported hand sinks into
        what it pushes and leaves it behind."""
        arm = self.scene.arms[arm_index]
        dense = time_path(np.asarray(configurations),
                          MotionLimits((speed,), (self.settings.acceleration,)),
                          self.world.config.time_step)
        held = self.held.get(arm_index)
        self.driving = drive
        try:
            self._follow_dense(arm_index, dense, held, drive)
        finally:
            self.driving = False
            if drive:
                self._drive_joints(arm_index, np.zeros(arm.dof))

    def follow_skill(self, path: ArmPath, reverse: bool = False) -> None:
        """Drive the arm through ``path.configurations`` (backwards with ``reverse``) so that
        the held tool moves as in the trials of the skill ``path.kind``
        (:data:`SKILL_TIMINGS`): each segment takes the longer of its distance / speed and
        its turn / angular speed, with no stop at the (dense) waypoints.

        A learned skill succeeds at the timing it was trained with: at the joint-speed
        limited, stop-at-every-waypoint timing of :meth:`follow`, a pour tilted at ~0.4
        rad/s peak instead of its trials' 2 rad/s, so its beads slid out over the lip one by
        one, off the cup's axis, instead of falling out together, and 21 of 40 flew past a
        bowl that the trials fill (Kitchen3D coffee, PyBullet)."""
        timing = SKILL_TIMINGS.get(path.kind)
        if timing is None:
            raise ActionFailed(f"{path.kind}: no skill timing for this kind of path")
        held = self.held.get(path.arm)
        if held is None:
            raise ActionFailed(f"{path.kind}: arm {path.arm} holds no tool")
        arm = self.scene.arms[path.arm]
        configurations = np.asarray(path.configurations, dtype=float)
        if reverse:
            configurations = configurations[::-1]
        start = arm.get_configuration()
        poses = []
        for q in configurations:
            arm.set_configuration(q)
            poses.append(arm.end_effector_pose() @ held[1])
        arm.set_configuration(start)
        dense = skill_timed_configurations(configurations, poses, timing.speed,
                                           timing.angular_speed, self.world.config.time_step)
        self._follow_dense(path.arm, dense, held, drive=False)

    def _drive_joints(self, arm_index: int, velocities: np.ndarray) -> None:
        """Joint velocities (rad/s) for the coming step, held by the joint motors."""
        arm = self.scene.arms[arm_index]
        p.resetJointStatesMultiDof(arm.body_id, PANDA_ARM_JOINTS,
                                   [[float(v)] for v in arm.get_configuration()],
                                   targetVelocities=[[float(v)] for v in velocities],
                                   physicsClientId=arm.client_id)
        p.setJointMotorControlArray(arm.body_id, PANDA_ARM_JOINTS, p.VELOCITY_CONTROL,
                                    targetVelocities=[float(v) for v in velocities],
                                    forces=[DRIVE_FORCE_N] * len(PANDA_ARM_JOINTS),
                                    physicsClientId=arm.client_id)

    def _follow_dense(self, arm_index: int, dense: np.ndarray, held: tuple[str, Pose] | None,
                      drive: bool) -> None:
        arm = self.scene.arms[arm_index]
        dt = self.world.config.time_step
        for i, q in enumerate(dense):
            self.commanded[arm_index] = q
            self._hold_arms(moving=arm_index)
            if held is not None:
                nxt = None
                if i + 1 < len(dense):
                    arm.set_configuration(dense[i + 1])
                    nxt = arm.end_effector_pose() @ held[1]
                arm.set_configuration(q)
                self._carry(arm_index, held[0], held[1], nxt)
            else:
                arm.set_configuration(q)
            if drive and i + 1 < len(dense):
                self._drive_joints(arm_index, (dense[i + 1] - q) / dt)
            for other, (name, grasp) in self.held.items():
                if other != arm_index:
                    self._carry(other, name, grasp, None)
            self._step()
            if self.probe is not None:
                self.probe()

    # Measurements ------------------------------------------------------------------------

    def counts(self) -> dict[str, dict[str, int]]:
        """Beads of each material contained in each cup/bowl."""
        containers = {n: b for n, b in self.bodies.items()
                      if self.spec.objects[n].kind in ("cup", "bowl")}
        out: dict[str, dict[str, int]] = {}
        for material, ids in self.beads.items():
            positions = bead_positions(self.world.client, ids)
            out[material] = {n: int(contained_mask(b, positions).sum())
                             for n, b in containers.items()}
            out[material]["total"] = len(ids)
            out[material]["off_table"] = count_lost(positions, floor_z=self.table_z - 0.05)
        return out

    def object_xy(self, name: str) -> tuple[float, float]:
        position, _ = self.bodies[name].pose()
        return float(position[0]), float(position[1])

    def material_positions(self, material: str) -> np.ndarray:
        """World positions ``(n, 3)`` of the beads of ``material``."""
        return bead_positions(self.world.client, self.beads[material])

    def inside(self, name: str, positions: np.ndarray) -> np.ndarray:
        """Which of ``positions`` ``(n, 3)`` lie in ``name``'s containment prism: ``(n,)``."""
        return contained_mask(self.bodies[name], positions)

    # Actions -----------------------------------------------------------------------------

    def grasp_pose(self, name: str, grasp: Any) -> Pose:
        grasps = object_grasps(self.spec.objects[name], self.spec.n_arms)
        return grasps[int(grasp[1])].tool_in_gripper

    def move(self, path: ArmPath) -> None:
        carrying = any(self.spec.objects[n].contents is not None or self.spec.objects[n].kind
                       == "spoon" for n, _ in self.held.values())
        if not carrying:
            self.follow(path.arm, path.configurations, self.settings.free_speed)
            return
        self.follow(path.arm, path.configurations, self.settings.carry_speed)

    def perceived_approach(self, name: str, grasp: Any, path: ArmPath) -> np.ndarray:
        """The approach ``(n, 7)`` of ``path`` moved with the object: the plan's approach
        when ``name`` stands where the plan expected it (the pose the grasp reaches at the
        path's end), otherwise the hand poses of the approach carried along with the
        object's actual offset and re-solved by IK from the current configuration."""
        arm = self.scene.arms[path.arm]
        configurations = np.asarray(path.configurations)
        current = arm.get_configuration()
        in_hand = self.grasp_pose(name, grasp)
        expected = arm.forward_kinematics(configurations[-1]) @ in_hand
        hands = [arm.forward_kinematics(q) for q in configurations]
        arm.set_configuration(current)
        actual = Pose(*self.bodies[name].pose())
        if self.spec.objects[name].kind in REVOLVED_KINDS:
            actual = without_spin(actual, expected)
        offset = float(np.linalg.norm(actual.position - expected.position))
        turn = rotation_distance(actual, expected)
        if offset <= REPERCEIVE_M and turn <= REPERCEIVE_RAD:
            return configurations
        if offset > REPERCEIVE_MAX_M:
            raise ActionFailed(f"pick {name}: it stands {offset:.3f} m from where it was "
                               "expected")
        shift = actual @ expected.inverse()
        # From where the hand is now (the plan's pre-grasp) over to the shifted approach.
        here = arm.end_effector_pose()
        found = follow_tool_path(arm, [here, *(shift @ hand for hand in hands)], Pose(),
                                 np.random.default_rng(0), start_configuration=current)
        if not found.success or found.configurations is None:
            if offset <= REPERCEIVE_OPEN_LOOP_M and turn <= REPERCEIVE_OPEN_LOOP_RAD:
                # A nudge of a few millimetres (a finger brushed the object while picking
                # its neighbour) is within what the open fingers take: the plan's approach.
                self.log.append({"action": "perceive", "object": name, "offset_m": offset,
                                 "turn_rad": turn, "open_loop": found.status})
                return configurations
            raise ActionFailed(f"pick {name}: no approach to where it stands "
                               f"({offset:.3f} m, {turn:.2f} rad off): {found.status}")
        self.log.append({"action": "perceive", "object": name, "offset_m": offset,
                         "turn_rad": turn})
        approach = np.asarray(found.configurations).copy()
        approach[0] = current  # the IK solve of the hand's own pose: back to it exactly
        return approach

    def pick(self, name: str, grasp: Any, path: ArmPath) -> None:
        arm = self.scene.arms[path.arm]
        arm.open_gripper()
        approach = self.perceived_approach(name, grasp, path)
        path = ArmPath(path.arm, approach, path.kind, path.held, path.touching, path.target)
        self.follow(path.arm, path.configurations, self.settings.free_speed / 2)
        width = object_grasps(self.spec.objects[name], self.spec.n_arms)[int(grasp[1])].width
        arm.set_finger_opening(max(width - 0.002, 0.0))
        gaps = [min((c[8] for c in p.getClosestPoints(
            arm.body_id, self.bodies[name].body, 0.05, linkIndexA=link,
            physicsClientId=self.world.client)), default=1.0) for link in (9, 10)]
        if max(gaps) > FINGER_CONTACT_M:
            raise ActionFailed(f"pick {name}: fingers {np.round(gaps, 4).tolist()} m from it")
        self.held[path.arm] = (name, self.grasp_pose(name, grasp))
        self.pinned.pop(name, None)
        self._scale_mass(name, HELD_MASS_FACTOR)
        self.follow(path.arm, path.configurations[::-1], self.settings.free_speed / 2)
        self.log.append({"action": "pick", "object": name, "finger_gaps_m": gaps})

    def _scale_mass(self, name: str, factor: float) -> None:
        """Multiply the mass of every piece of ``name`` by ``factor`` (kg)."""
        body = self.bodies[name].body
        client = self.world.client
        for link in range(-1, p.getNumJoints(body, physicsClientId=client)):
            mass = p.getDynamicsInfo(body, link, physicsClientId=client)[0]
            p.changeDynamics(body, link, mass=mass * factor, physicsClientId=client)

    def place(self, name: str, xy: tuple[float, float], path: ArmPath) -> None:
        self.follow(path.arm, path.configurations, self.settings.free_speed / 2)
        del self.held[path.arm]
        self._scale_mass(name, 1.0 / HELD_MASS_FACTOR)
        arm = self.scene.arms[path.arm]
        arm.open_gripper()
        self.bodies[name].set_pose(*self.bodies[name].pose())  # released at rest
        if self.spec.objects[name].kind in TOOL_KINDS:
            self.pinned[name] = self.bodies[name].pose()
        self.follow(path.arm, path.configurations[::-1], self.settings.free_speed / 2)
        self.step_n(self.world.steps_for(self.settings.settle_s))
        rest = self.object_xy(name)
        error = float(np.hypot(rest[0] - xy[0], rest[1] - xy[1]))
        self.log.append({"action": "place", "object": name, "error_m": error})
        if error > PLACE_TOLERANCE_M:
            raise ActionFailed(f"place {name}: came to rest {error:.3f} m from its pose")

    def pour(self, path: ArmPath) -> None:
        """Tilt the held cup along the pour path at the pour skill's own speeds (those of
        the trials its model learned from), hold, and carry it back upright (all in the
        pour trials' physics, :meth:`skill_physics`)."""
        with self.skill_physics("pour"):
            self.follow_skill(path)
            self.step_n(self.world.steps_for(self.settings.pour_hold_s))
            self.follow(path.arm, path.configurations[::-1], self.settings.carry_speed)
            self.step_n(self.world.steps_for(self.settings.settle_s))
        self.log.append({"action": "pour", "counts": self.counts()})

    def scoop(self, spoon: str, bowl: str, material: str, path: ArmPath) -> None:
        """Drag the held spoon through ``bowl`` and lift it out (forward only); record the
        spoonful of ``material`` once the beads in the head have settled (both in the scoop
        trials' physics, :meth:`skill_physics`)."""
        if material not in self.beads:
            raise ActionFailed(f"scoop: no beads of {material!r} in the kitchen")
        with self.skill_physics("scoop"):
            self.follow_skill(path)
            self.step_n(self.world.steps_for(self.settings.settle_s))
        spoonful = int(self.inside(spoon, self.material_positions(material)).sum())
        self.spoonfuls[material] = spoonful
        self.log.append({"action": "scoop", "spoon": spoon, "bowl": bowl, "material": material,
                         "spoonful": spoonful})
        if spoonful < SCOOP_CONTAINS_MIN_BEADS:
            raise ActionFailed(f"scoop: the spoon lifted only {spoonful} beads of {material}")

    def dump(self, spoon: str, cup: str, material: str, path: ArmPath) -> None:
        """Turn the held spoon over above ``cup``, hold, turn it back."""
        self.follow(path.arm, path.configurations, self.settings.dump_speed)
        self.step_n(self.world.steps_for(self.settings.pour_hold_s))
        self.follow(path.arm, path.configurations[::-1], self.settings.carry_speed)
        self.step_n(self.world.steps_for(self.settings.settle_s))
        left = (int(self.inside(spoon, self.material_positions(material)).sum())
                if material in self.beads else 0)
        self.log.append({"action": "dump", "spoon": spoon, "cup": cup, "material": material,
                         "left_in_spoon": left, "counts": self.counts()})

    def stir(self, stirrer: str, cup: str, path: ArmPath) -> None:
        """Follow the stir path into ``cup`` and back out, tracking the stirrer's tip (its
        object frame's origin) in the cup's frame at every step."""
        cavity = self.bodies[cup].geometry.cavity
        if cavity is None:
            raise ActionFailed(f"stir: {cup} is not a container")
        tracker = TipTracker(cavity, self.world.config.time_step)
        before = self.counts()

        def track() -> None:
            tip, _ = self.bodies[stirrer].pose()
            tracker.add(world_to_object(tip[None, :], *self.bodies[cup].pose())[0])

        self.probe = track
        try:
            with self.skill_physics("stir"):
                self.follow_skill(path)
                self.follow_skill(path, reverse=True)
        finally:
            self.probe = None
        with self.skill_physics("stir"):
            self.step_n(self.world.steps_for(self.settings.settle_s))
        record = {"action": "stir", "stirrer": stirrer, "cup": cup, **tracker.to_json(),
                  "counts_before": before, "counts_after": self.counts()}
        self.stirs.setdefault(cup, []).append(record)
        self.log.append(record)

    def push_finger_gap(self, arm_index: int, name: str, goal: tuple[float, float]) -> float:
        """The finger gap (m) the push path of arm ``arm_index`` was planned for
        (:func:`~.tamp.skill_paths.push_finger_gap`): the fingers, opened, lie across the
        line from ``name`` to ``goal`` or along it (measured at the arm's configuration)."""
        arm = self.scene.arms[arm_index]
        arm.open_gripper()
        tips = [np.asarray(p.getLinkState(arm.body_id, link, computeForwardKinematics=True,
                                          physicsClientId=arm.client_id)[4])
                for link in PANDA_FINGER_JOINTS]
        direction = np.subtract(goal, self.object_xy(name))
        return push_finger_gap(self.spec.objects[name], fingers_across(tips[1] - tips[0],
                                                                       direction))

    def push(self, name: str, goal: tuple[float, float], path: ArmPath) -> None:
        """Set the empty hand's fingers (open across the line for a round object, else
        closed: :meth:`push_finger_gap`) and follow the push path (forward only); ``name``
        must come to rest within :data:`PUSH_TOLERANCE_M` of ``goal``."""
        if path.arm in self.held:
            raise ActionFailed(f"push {name}: arm {path.arm} is holding something")
        gap = self.push_finger_gap(path.arm, name, goal)
        self.scene.arms[path.arm].set_finger_opening(gap)
        start = self.object_xy(name)
        with self.skill_physics("push"):
            self.follow(path.arm, path.configurations, self.settings.push_speed, drive=True)
            self.step_n(self.world.steps_for(self.settings.settle_s))
        rest = self.object_xy(name)
        error = float(np.hypot(rest[0] - goal[0], rest[1] - goal[1]))
        self.log.append({"action": "push", "object": name, "start_xy": start, "rest_xy": rest,
                         "error_m": error, "finger_gap_m": gap,
                         "planned_finger_gap_m": path.finger_gap})
        if error > PUSH_TOLERANCE_M:
            raise ActionFailed(f"push {name}: came to rest {error:.3f} m from its target")

    def run_step(self, name: str, values: Sequence[Any],
                 args: Sequence[str] | None = None) -> None:
        """Execute one plan step: ``values`` are its argument values, ``args`` (optional)
        its argument objects' names (symbolic objects such as materials are named there)."""

        def obj(i: int) -> str:
            return str(args[i] if args is not None else values[i]).lower()

        def xy(i: int) -> tuple[float, float]:
            return float(values[i][0]), float(values[i][1])

        actions: dict[str, Callable[[], None]] = {
            "move-free": lambda: self.move(values[1]),
            "move-holding": lambda: self.move(values[3]),
            "pick": lambda: self.pick(obj(0), values[2], values[4]),
            "place": lambda: self.place(obj(0), xy(1), values[4]),
            "pour": lambda: self.pour(values[5]),
            "scoop": lambda: self.scoop(obj(0), obj(2), obj(8), values[6]),
            "dump": lambda: self.dump(obj(0), obj(2), obj(6), values[5]),
            "stir": lambda: self.stir(obj(0), obj(2), values[5]),
            "push": lambda: self.push(obj(0), xy(2), values[5]),
        }
        if name not in actions:
            raise ActionFailed(f"cannot execute action {name!r}")
        actions[name]()

    # Goal --------------------------------------------------------------------------------

    def check(self, predicate: str, args: tuple[str, ...]) -> tuple[bool, dict[str, Any]]:
        if predicate == "contains":
            container, material = args
            counts = self.counts().get(material)
            if counts is None:
                return False, {"reason": f"no beads of {material}"}
            if material in self.spoonfuls:
                spoonful = self.spoonfuls[material]
                held = counts.get(container, 0)
                need = max(SCOOP_CONTAINS_MIN_BEADS,
                           math.ceil(SCOOP_CONTAINS_FRACTION * spoonful))
                return held >= need, {"beads": held, "spoonful": spoonful, "counts": counts}
            start = self.initial_counts[material]
            inside_start = max(v for k, v in start.items() if k not in ("total", "off_table"))
            fraction = counts.get(container, 0) / max(inside_start, 1)
            return fraction >= CONTAINS_FRACTION, {"fraction": fraction, "counts": counts}
        if predicate == "on":
            name, region = args
            xy = self.object_xy(name)
            area = self.spec.regions[region]
            return area.contains(xy), {"xy": xy}
        if predicate == "holding":
            return any(n == args[0] for n, _ in self.held.values()), {}
        if predicate == "stirred":
            records = self.stirs.get(args[0], [])
            return any(r["stirred"] for r in records), {
                "stirs": [{k: r[k] for k in ("tip_time_inside_s", "tip_travel_inside_m")}
                          for r in records]}
        raise ActionFailed(f"cannot check goal fact ({predicate} {' '.join(args)}) physically")


class Kitchen3DExecutor:
    """:class:`~ltamp_cli.backends.execution.PlanExecutor` for kitchen3d plans."""

    #: The simulation that replays the actions (the SAPIEN backend substitutes its own).
    run_class: type[Kitchen3DRun] = Kitchen3DRun

    def __init__(self, settings: ExecutionSettings | None = None,
                 camera: Camera | None = None, timing: GifTiming | None = None) -> None:
        self.settings = settings or ExecutionSettings()
        # The direction and image size; the recorder moves the camera to frame the scene.
        self.camera = camera or Camera(target=(0.0, 0.0, 0.75), distance=1.3, yaw=50.0,
                                       pitch=-30.0, width=640, height=480)
        self.timing = timing or GifTiming()

    def execute(self, problem: Any, plan_result: Any, seed: int,
                render_path: str | Path | None = None) -> ExecutionReport:
        spec = scene_from_world(problem.world)
        poses: dict[str, tuple[float, float]] = {}
        for atom in problem.init:
            if atom.predicate.lower() == "atpose":
                name, pose = (a.lower() for a in atom.args)
                value = problem.objects.get(pose, (None, None))[1]
                if value is not None:
                    poses[name] = (float(value[0]), float(value[1]))
        run = self.run_class(spec, poses, seed, self.settings,
                             self.camera if render_path is not None else None)
        steps: list[dict[str, Any]] = []
        success = True
        try:
            plan = plan_result.plan or ()
            kinds = {name: obj.kind for name, obj in spec.objects.items()}
            for index, step in enumerate(plan):
                names = step.args or ()  # a plan made by hand may name no arguments
                run.film(action_caption(index + 1, len(plan), step.name, names),
                         action_focus(names, kinds))
                try:
                    run.run_step(step.name, step.values, step.args)
                    steps.append({"index": index, "action": step.name, "ok": True})
                except ActionFailed as error:
                    steps.append({"index": index, "action": step.name, "ok": False,
                                  "error": str(error)})
                    success = False
                    break
            facts = []
            goal_holds = success
            for predicate, args in _goal_atoms(problem.goal):
                holds, measured = run.check(predicate, args)
                facts.append({"fact": f"({predicate} {' '.join(args)})", "holds": holds,
                              **measured})
                goal_holds = goal_holds and holds
            details = {"steps": steps, "goal": facts, "log": run.log,
                       "sim_steps": run.steps,
                       "sim_time_s": run.steps * run.world.config.time_step,
                       "initial_counts": run.initial_counts}
            if render_path is not None and run.recorder is not None:
                run.film("goal " + ("holds" if goal_holds else "does not hold"), None)
                run.step_n(run.world.steps_for(1.0))  # a last second saying how it ended
                written = run.recorder.save(Path(render_path), self.timing)
                details["render"] = written["path"]
                details["animation"] = written
            return ExecutionReport(success, bool(goal_holds), details)
        finally:
            run.close()


__all__ = ["SKILL_TIMINGS", "ActionFailed", "ExecutionSettings", "Kitchen3DExecutor",
           "Kitchen3DRun", "SkillTiming", "skill_timed_configurations"]
