"""The geometry behind the Kitchen3D streams: one headless PyBullet world with the table, the
arms and one collision body per object, queried for IK, motions and collisions.

Fixed objects stand at their ``at`` pose and are obstacles of every query. Movable objects
are parked far away and brought in only for the query that involves them: their collisions
with paths are separate tests (``CFreeTraj``) that the domain uses negated, so that the
planner knows *which* object is in the way and can move it.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p

from ltamp_cli.backends.pybullet.kitchenware import (
    BodyMaterial,
    KitchenwareBody,
    create_kitchenware,
)
from ltamp_cli.backends.pybullet.robot.arm import PANDA_HOME
from ltamp_cli.backends.pybullet.robot.cartesian import CartesianConfig, follow_tool_path
from ltamp_cli.backends.pybullet.robot.collision import ArmCollisionChecker, AttachedBody
from ltamp_cli.backends.pybullet.robot.grasps import Grasp
from ltamp_cli.backends.pybullet.robot.ik import IKConfig
from ltamp_cli.backends.pybullet.robot.motion import plan_arm_motion
from ltamp_cli.backends.pybullet.robot.pose import Pose
from ltamp_cli.backends.pybullet.robot.scene import KitchenScene, build_kitchen_scene
from ltamp_cli.backends.pybullet.tamp.grasping import approach_direction, object_grasps
from ltamp_cli.backends.pybullet.tamp.scene import XY, SceneSpec
from ltamp_cli.backends.pybullet.tamp.values import ArmConf, ArmPath, GraspValue
from ltamp_cli.motion.interpolation import densify_path
from ltamp_cli.motion.rrt_connect import RRTConnectConfig

#: Pre-grasp: the hand backs off this far (m) along its approach axis, and lifts this much.
RETREAT_M = 0.08
LIFT_M = 0.02
#: Joint resolution (rad) of dense path collision tests.
CHECK_RESOLUTION = 0.04
PARK_DISTANCE_M = 20.0
#: How far (m) motions keep from the movable objects known to stand in their way.
MOVABLE_CLEARANCE_M = 0.01
FOOTPRINT_MARGIN_M = 0.01


def pose_of(xy: Sequence[float], table_z: float, yaw: float = 0.0) -> Pose:
    """World pose of an upright object whose base centre is at ``xy`` on the table."""
    return Pose.from_euler(np.array([float(xy[0]), float(xy[1]), table_z]), yaw=yaw)


@dataclass(frozen=True)
class PlanningSettings:
    """Speed/robustness knobs of the geometric queries.

    RRT budgets count collision checks (``rrt_checks``; ``rrt_carry_checks`` for motions
    carrying contents, whose tilt limit leaves a thin free space), so a query's outcome
    depends on its seed, not on the machine's load; ``rrt_time_s``/``rrt_carry_time_s``
    (CPU seconds of the planning thread, so that a loaded machine does not cut a query
    short) only cap a query on a very slow machine. A check costs ~0.15-0.27 ms
    free and ~0.55-0.67 ms carrying (pour_blocked, coffee; one core), so 5,000 checks are
    about the earlier wall budgets of 1 s free / 3 s carrying on an idle core (one
    push_to_reach carry: 4/12 solved with 1 s, 9/12 with 3 s). Solved queries used ~1,000
    checks (median), at most ~5,800."""

    rrt_checks: int = 5000
    rrt_carry_checks: int = 5000
    rrt_time_s: float = 6.0
    rrt_carry_time_s: float = 15.0
    ik_restarts: int = 8
    cartesian_restarts: int = 3


class PlanningWorld:
    """A PyBullet ``DIRECT`` client with the kitchen scene of ``spec`` (closed on collection)."""

    def __init__(self, spec: SceneSpec, settings: PlanningSettings | None = None) -> None:
        self.spec = spec
        self.settings = settings or PlanningSettings()
        self.client = p.connect(p.DIRECT)
        if self.client < 0:
            raise RuntimeError("could not connect to a PyBullet physics server")
        self._finalizer = weakref.finalize(self, p.disconnect, self.client)
        self.scene: KitchenScene = build_kitchen_scene(self.client, spec.n_arms, spec.table)
        self.table_z = float(self.scene.table.height)
        self.bodies: dict[str, KitchenwareBody] = {}
        self.grasps: dict[str, list[Grasp]] = {}
        self._park_slot = {name: i for i, name in enumerate(spec.objects)}
        for index, (name, obj) in enumerate(spec.objects.items()):
            body = create_kitchenware(self.client, obj.geometry(), material=BodyMaterial(mass=0.0),
                                      visual=False)
            self.bodies[name] = body
            self.grasps[name] = object_grasps(obj, spec.n_arms)
            if obj.fixed and obj.at is not None:
                self.place(name, obj.at)
            else:
                self.park(name, index)
        self.cartesian = CartesianConfig(ik=IKConfig(restarts=self.settings.ik_restarts),
                                         path_restarts=self.settings.cartesian_restarts)

    def close(self) -> None:
        self._finalizer()

    # Bodies ------------------------------------------------------------------------------

    def place(self, name: str, xy: Sequence[float]) -> None:
        pose = pose_of(xy, self.table_z)
        self.bodies[name].set_pose(pose.position, pose.quaternion)

    def park(self, name: str, slot: int | None = None) -> None:
        index = self._park_slot[name] if slot is None else slot
        self.bodies[name].set_pose((PARK_DISTANCE_M + 2.0 * index, PARK_DISTANCE_M, 0.0))

    def fixed_bodies(self, exclude: Sequence[str] = ()) -> tuple[int, ...]:
        return tuple(self.bodies[n].body for n, o in self.spec.objects.items()
                     if o.fixed and n not in exclude)

    def obstacles(self, arm: int, extra: Sequence[str] = (), exclude: Sequence[str] = ()
                  ) -> tuple[int, ...]:
        """Static scenery, the other arm, the fixed objects (but ``exclude``) and the named
        movable ones."""
        bodies = (*self.fixed_bodies(exclude), *(self.bodies[name].body for name in extra))
        return self.scene.obstacles_for(arm, bodies)

    def grasp(self, name: str, grasp: GraspValue) -> Grasp:
        return self.grasps[name][grasp[1]]

    def rest_other_arms(self, arm: int) -> None:
        """Put every arm but ``arm`` at its home configuration: an arm's queries see the
        other arm there (the planner does not track it; the executor starts it there)."""
        for index, other in enumerate(self.scene.arms):
            if index != arm:
                other.set_configuration(np.asarray(PANDA_HOME))

    def checker(self, arm: int, held: tuple[str, GraspValue] | None = None,
                extra: Sequence[str] = (), carries_contents: bool = True,
                exclude: Sequence[str] = (), clearance: float = 0.0,
                only_extra: bool = False) -> ArmCollisionChecker:
        """Collision checker of arm ``arm`` (the other arms at home, see
        :meth:`rest_other_arms`), carrying ``held``, with movable objects ``extra``.
        ``clearance`` (m): how far the arm and ``held`` keep from the obstacles;
        ``only_extra``: the obstacles are ``extra`` alone (no scenery, no self-collision),
        for a second checker that adds a clearance to some objects only."""
        self.rest_other_arms(arm)
        attached = None
        if held is not None:
            name, g = held
            # A spoon may carry a spoonful (the stream cannot know the fluent): keep it level.
            spec = self.spec.objects[name]
            carrying = carries_contents and (spec.contents is not None or spec.kind == "spoon")
            attached = AttachedBody(self.bodies[name].body, self.grasp(name, g).tool_in_gripper,
                                    carrying)
        if only_extra:
            return ArmCollisionChecker(self.scene.arms[arm],
                                       tuple(self.bodies[name].body for name in extra),
                                       attached, clearance=clearance, self_collision=False)
        return ArmCollisionChecker(self.scene.arms[arm], self.obstacles(arm, extra, exclude),
                                   attached, clearance=clearance)

    # Stream queries ----------------------------------------------------------------------

    def grasp_values(self, name: str) -> list[GraspValue]:
        return [(g.kind, i) for i, g in enumerate(self.grasps[name])]

    def pick_kinematics(self, name: str, xy: XY, grasp: GraspValue, rng: np.random.Generator,
                        arms: Sequence[int] | None = None) -> Iterator[tuple[ArmConf, ArmPath]]:
        """For each of ``arms`` (default: all) that reaches it: the pre-grasp conf and the
        approach path to the grasp (checked with ``name`` at ``xy`` as an obstacle, and
        carrying it back out)."""
        g = self.grasp(name, grasp)
        object_pose = pose_of(xy, self.table_z)
        at_grasp = g.gripper_pose(object_pose)
        above = Pose(at_grasp.position + np.array([0.0, 0.0, LIFT_M]), at_grasp.quaternion)
        back = above @ Pose(np.array([0.0, 0.0, -RETREAT_M]))
        for arm in range(self.spec.n_arms) if arms is None else arms:
            self.place(name, xy)
            try:
                into = follow_tool_path(self.scene.arms[arm], [back, above, at_grasp], Pose(), rng,
                                        is_valid=self.checker(arm, extra=(name,)),
                                        config=self.cartesian)
                if not into.success:
                    continue
                assert into.configurations is not None
                out = self.checker(arm, held=(name, grasp), carries_contents=False)
                # Leaving with the object: it must clear everything fixed as it is lifted.
                if not all(out(q) for q in densify_path(into.configurations[::-1],
                                                         CHECK_RESOLUTION)):
                    continue
            finally:
                self.park(name)
            configs = into.configurations
            yield (ArmConf.of(arm, configs[0]),
                   ArmPath(arm, configs, "approach", None, touching=name))

    def plan_motion(self, q1: ArmConf, q2: ArmConf, held: tuple[str, GraspValue] | None,
                    seed: int, standing: Sequence[tuple[str, XY]] = (),
                    straight_first: bool = True) -> ArmPath | None:
        """A collision-free path between two confs of the same arm (carrying ``held``): the
        straight joint-space segment (unless not ``straight_first``), else RRT-Connect.

        ``standing``: movable objects to keep clear of at these poses, such as the object
        a pick conf picks or a place conf has just placed (it stands there whenever the
        arm is at that conf), so that the path does not sweep through the very object the
        arm reaches for. The path keeps :data:`MOVABLE_CLEARANCE_M` from them where its end
        confs do (an executed carry lags behind its path, and a block lifted past a cup
        with millimetres to spare dragged it over); one that an end conf itself touches is
        left out (the planner's ``CFreeTraj`` tests still see it)."""
        if q1.arm != q2.arm or q1 == q2:
            return None
        arm = self.scene.arms[q1.arm]
        near: list[str] = []  # obstacles kept at the clearance
        touching: list[str] = []  # obstacles only not to be hit
        for name, xy in standing:
            self.place(name, xy)
            for clearance, group in ((MOVABLE_CLEARANCE_M, near), (0.0, touching)):
                alone = self.checker(q1.arm, held, extra=(name,), clearance=clearance,
                                     only_extra=True)
                if alone(q1.array) and alone(q2.array):
                    group.append(name)
                    break
            else:  # an end conf touches it: leave it to the planner's CFreeTraj tests
                self.park(name)
        names = near + touching
        base = self.checker(q1.arm, held, extra=touching)
        clear = self.checker(q1.arm, held, extra=near, clearance=MOVABLE_CLEARANCE_M,
                             only_extra=True) if near else None

        def checker(q: np.ndarray) -> bool:
            return base(q) and (clear is None or clear(q))

        budget, checks = self.settings.rrt_time_s, self.settings.rrt_checks
        if base.attached is not None and base.attached.carries_contents:
            budget, checks = self.settings.rrt_carry_time_s, self.settings.rrt_carry_checks
        try:
            plan = plan_arm_motion(arm, q1.array, q2.array, checker,
                                   RRTConnectConfig(time_limit=budget, seed=seed,
                                                    max_checks=checks),
                                   straight_first=straight_first)
        finally:
            if held is not None:
                self.park(held[0])
            for name in names:
                self.park(name)
        if plan.path is None:
            return None
        return ArmPath(q1.arm, plan.path, "holding" if held else "free", held)

    def follow_object_path(self, name: str, grasp: GraspValue, poses: Sequence[Pose], arm: int,
                           rng: np.random.Generator, kind: str, target: str | None = None
                           ) -> ArmPath | None:
        """``follow-obj-path``: arm configurations carrying ``name`` along ``poses``
        (world), collision-free with the fixed scenery; no tilt limit (the skill tilts).

        ``target``: the object the *held tool* works in and may touch (a spoon dragged
        through a bowl; the skill's own geometric pre-check has validated that path against
        it); the arm must still clear it. A fixed target is checked here, a movable one by
        :meth:`path_collides`."""
        g = self.grasp(name, grasp)
        touchable = (target,) if target is not None and self.spec.objects[target].fixed else ()
        checker = self.checker(arm, held=(name, grasp), carries_contents=False,
                               exclude=touchable)
        is_valid: Callable[[np.ndarray], bool] = checker
        if touchable:
            target_body = self.bodies[touchable[0]].body
            robot = self.scene.arms[arm].body_id

            def is_valid(q: np.ndarray) -> bool:  # the arm alone against the target
                if not checker(q):
                    return False
                points = p.getClosestPoints(robot, target_body, 0.0, physicsClientId=self.client)
                return not any(c[8] < -1e-3 for c in points)

        try:
            found = follow_tool_path(self.scene.arms[arm], poses, g.tool_in_gripper, rng,
                                     is_valid=is_valid, config=self.cartesian)
        finally:
            self.park(name)
        if not found.success:
            return None
        assert found.configurations is not None
        return ArmPath(arm, found.configurations, kind, (name, grasp), target=target)

    def aimed_home(self, arm: int, xy: Sequence[float]) -> np.ndarray:
        """Arm ``arm``'s home configuration (7,) with its first joint turned to face the
        table point ``xy`` (world, m): the elbow-up, palm-down posture a path starting
        above ``xy`` is best solved from."""
        base = self.base_xy(arm)
        base_yaw = 0.0 if arm == 0 else math.pi  # the scene's arms face each other
        heading = math.atan2(float(xy[1]) - base[1], float(xy[0]) - base[0]) - base_yaw
        q = np.asarray(PANDA_HOME, dtype=float).copy()
        q[0] = (heading + math.pi) % (2.0 * math.pi) - math.pi
        return q

    def follow_hand_path(self, poses: Sequence[Pose], arm: int, rng: np.random.Generator,
                         kind: str, touching: str | None = None,
                         finger_gap: float | None = None) -> ArmPath | None:
        """Arm configurations moving the empty hand's grasp target along ``poses`` (world),
        collision-free with the fixed scenery (movable objects: ``CFreeTraj``), the hand's
        fingers ``finger_gap`` (m) apart (``None``: fully open) as they will be executed.

        The first pose is solved from :meth:`aimed_home` first, then from the arm's current
        configuration (home). Solved from home alone (every restart of the Cartesian
        follower solves the first pose from the same configuration), arm r1's push of
        push_to_reach's bowl with the fingers across the line landed on a twisted elbow
        (joint 3 at -1.2 rad) whose joints then ran away along the descent ("IK failed or
        jumped" 4 waypoints down): found for 6 of 16 targets in the middle region, 15 of 16
        with the aimed posture first (``bench/push_exec_diag.py --reach-map 4``)."""
        robot = self.scene.arms[arm]
        opening = robot.finger_opening()
        here = robot.get_configuration()
        found = None
        try:
            if finger_gap is not None:
                robot.set_finger_opening(finger_gap)
            for seed in (self.aimed_home(arm, poses[0].position[:2]), here):
                robot.set_configuration(seed)
                found = follow_tool_path(robot, poses, Pose(), rng, is_valid=self.checker(arm),
                                         config=self.cartesian)
                if found.success:
                    break
        finally:
            robot.set_configuration(here)
            robot.set_finger_opening(opening)
        if found is None or not found.success:
            return None
        assert found.configurations is not None
        return ArmPath(arm, found.configurations, kind, None, touching=touching,
                       finger_gap=finger_gap)

    def base_xy(self, arm: int) -> XY:
        """Where arm ``arm``'s base stands (x, y), metres."""
        base = p.getBasePositionAndOrientation(self.scene.arms[arm].body_id,
                                               physicsClientId=self.client)[0]
        return float(base[0]), float(base[1])

    def base_yaw(self, arm: int, xy: XY) -> float:
        """Heading (radians) from arm ``arm``'s base to the table point ``xy``."""
        base = self.base_xy(arm)
        return math.atan2(float(xy[1]) - base[1], float(xy[0]) - base[0])

    def skill_yaws(self, name: str, grasp: GraspValue, arm: int) -> list[tuple[float, float]]:
        """``(ψ, φ)`` pairs for a skill whose tool tilts about its skill-frame ``y`` axis:
        the skill frame is turned by ``ψ`` about the target, the tool by ``φ`` about its own
        axis, so that the hand's approach lies along the tilt axis and points away from the
        arm's base (the wrist's last joint then does the tilting)."""
        approach = approach_direction(self.grasp(name, grasp))
        a_obj = math.atan2(approach[1], approach[0])
        forward = 0.0 if arm == 0 else math.pi
        pairs = []
        for sign in (1.0, -1.0):
            along = math.pi / 2 if sign > 0 else -math.pi / 2  # angle of ±y_s
            pairs.append((forward - along, along - a_obj))
        return pairs

    def path_collides(self, path: ArmPath, name: str, xy: XY) -> bool:
        """Does ``path`` (and what it holds) hit movable object ``name`` standing at ``xy``?"""
        if (self.spec.objects[name].fixed or name == path.touching
                or (path.held is not None and path.held[0] == name)):
            return False
        arm = self.scene.arms[path.arm]
        body = self.bodies[name].body
        held_body = None
        held_grasp = None
        if path.held is not None:
            held_body = self.bodies[path.held[0]].body
            held_grasp = self.grasp(*path.held).tool_in_gripper
        opening = arm.finger_opening()
        if path.finger_gap is not None:
            arm.set_finger_opening(path.finger_gap)
        self.place(name, xy)
        try:
            for q in densify_path(path.configurations, CHECK_RESOLUTION):
                arm.set_configuration(q)
                points = p.getClosestPoints(arm.body_id, body, 0.0, physicsClientId=self.client)
                if any(c[8] < -1e-3 for c in points):
                    return True
                if held_body is not None and held_grasp is not None and name != path.target:
                    tool = arm.end_effector_pose() @ held_grasp
                    position, quaternion = tool.as_tuples()
                    p.resetBasePositionAndOrientation(held_body, position, quaternion,
                                                      physicsClientId=self.client)
                    points = p.getClosestPoints(held_body, body, 0.0, physicsClientId=self.client)
                    if any(c[8] < -1e-3 for c in points):
                        return True
            return False
        finally:
            arm.set_finger_opening(opening)
            self.park(name)
            if path.held is not None:
                self.park(path.held[0])

    def approach_collides(self, path: ArmPath, name: str, xy: XY, contact: Pose) -> bool:
        """Does the arm hit ``name`` (standing at ``xy``) on ``path`` before its hand first
        reaches ``contact`` (a push's pose behind the object, where touching it starts)?
        Push paths may touch what they push, but not on the way down to it (a palm coming
        down on a bowl's rim). The fingers are ``path.finger_gap`` apart, as the executor
        pushes (closed if the path does not say)."""
        arm = self.scene.arms[path.arm]
        configurations = np.asarray(path.configurations)
        # The hand passes ``contact`` once (straight down, then straight along the push).
        distances = [float(np.linalg.norm(arm.forward_kinematics(q).position - contact.position))
                     for q in configurations]
        end = int(np.argmin(distances)) + 1
        gap = 0.0 if path.finger_gap is None else path.finger_gap
        return self.path_collides(ArmPath(path.arm, configurations[:end], path.kind,
                                          finger_gap=gap), name, xy)

    def footprints_overlap(self, a: str, pa: XY, b: str, pb: XY) -> bool:
        ha = self.spec.objects[a].footprint()
        hb = self.spec.objects[b].footprint()
        return (abs(pa[0] - pb[0]) < ha[0] + hb[0] + FOOTPRINT_MARGIN_M
                and abs(pa[1] - pb[1]) < ha[1] + hb[1] + FOOTPRINT_MARGIN_M)
