"""Replaying kitchen3d plans in SAPIEN and checking the goal in the simulated world.

The action semantics are the PyBullet executor's (:class:`~ltamp_cli.backends.pybullet.
executor.Kitchen3DRun`: joint-speed-limited following of the planned paths, the pour,
scoop and stir at their skills' own tool speeds (``SKILL_TIMINGS``), picks that
verify both fingers are at the object, places checked where the object came to rest, the
goal checked from bead positions); only the simulation underneath is replaced:

* **physics in SAPIEN**: table, pedestals, kitchenware (fixed ones static, movable ones
  dynamic; a held object becomes kinematic and follows ``EE pose @ grasp``), beads;
* **kinematics shared**: the arms' forward kinematics and the finger-contact distance query
  use the backend-independent Panda model (:mod:`ltamp_cli.backends.pybullet.robot`, a
  never-stepped PyBullet client) that planning used, so nothing about IK or grasps is
  duplicated. Every arm link with collision geometry is mirrored into SAPIEN as a kinematic
  body (the URDF's collision meshes, no visuals), placed at the model's link poses before
  each step. Like the PyBullet executor's joint resets, the links are *teleported*: PhysX
  pushes whatever they overlap out of the way, but a link grazing an object (the planner
  tolerates ~1 mm) does not sweep it along with the arm's velocity, as kinematic targets
  would (infinitely heavy links dragged a grazed cup 2 cm and spilled it).
"""

from __future__ import annotations

import os
import sys
from contextlib import AbstractContextManager, nullcontext
from typing import Any

import numpy as np
import pybullet as p

from ltamp_cli.backends.pybullet.executor import (
    ACTION_SKILLS,
    FINGER_CONTACT_M,
    PLACE_TOLERANCE_M,
    TOOL_KINDS,
    ActionFailed,
    ExecutionSettings,
    Kitchen3DExecutor,
    Kitchen3DRun,
)
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial, KitchenwareBody
from ltamp_cli.backends.pybullet.kitchenware import create_kitchenware as create_mirror
from ltamp_cli.backends.pybullet.particles import BeadSpec, count_lost
from ltamp_cli.backends.pybullet.render import Camera
from ltamp_cli.backends.pybullet.replay import (
    BeadGroup,
    ReplayFrame,
    ReplayRecorder,
    ReplayScene,
    bead_rgba,
)
from ltamp_cli.backends.pybullet.robot.arm import (
    PANDA_FINGER_JOINTS,
    PANDA_FINGER_TRAVEL,
    PANDA_HOME,
    PandaArm,
)
from ltamp_cli.backends.pybullet.robot.pose import Pose
from ltamp_cli.backends.pybullet.robot.scene import KitchenScene, build_kitchen_scene
from ltamp_cli.backends.pybullet.tamp.grasping import object_grasps
from ltamp_cli.backends.pybullet.tamp.planning import pose_of
from ltamp_cli.backends.pybullet.tamp.scene import SceneSpec
from ltamp_cli.backends.pybullet.tamp.values import ArmPath
from ltamp_cli.backends.pybullet.world import PhysicsWorld
from ltamp_cli.backends.sapien.bodies import (
    Beads,
    SapienBody,
    contained_mask,
    create_kitchenware,
    physx_material,
    spawn_beads_in,
)
from ltamp_cli.backends.sapien.render import (
    CameraView,
    FrameRecorder,
    new_render_system,
    probe_render_device,
)
from ltamp_cli.backends.sapien.world import (
    SapienWorld,
    SapienWorldConfig,
    physx,
    sapien,
    to_sapien_pose,
)

#: Finger clearance (m, per side) when the gripper opens around an object. The PyBullet
#: executor opens fully (8 cm); a fully open finger beside a 4 cm block dips into a cup
#: standing 13 mm away and shoves it in PhysX.
PRESHAPE_CLEARANCE_M = 0.003

#: The kitchen seen from the front-right, above the table (metres).
KITCHEN_VIEW = CameraView(eye=(0.85, -0.85, 1.45), target=(0.0, 0.0, 0.75), width=640,
                          height=480)


def object_material(kind: str, rng: np.random.Generator, fixed: bool) -> BodyMaterial:
    """The PyBullet executor's per-object material, with the same draws from ``rng`` (so one
    seed gives both engines the same frictions and bead properties)."""
    friction = float(np.clip(rng.normal(0.5, 0.1), 0.2, 0.8))
    mass = 0.0 if fixed else {"cup": 0.15, "block": 0.2}.get(kind, 0.1)
    return BodyMaterial(mass=mass, lateral_friction=friction, restitution=0.1)


class SapienArm:
    """Kinematic SAPIEN bodies that follow a :class:`PandaArm` of the kinematic model."""

    def __init__(self, world: SapienWorld, arm: PandaArm) -> None:
        self.arm = arm
        client = arm.client_id
        material = physx_material(0.5, 0.0)
        self.links: list[tuple[int, Any, sapien.Entity]] = []
        scale = np.ones(3, dtype=np.float32)
        for link in range(-1, p.getNumJoints(arm.body_id, physicsClientId=client)):
            shapes = p.getCollisionShapeData(arm.body_id, link, physicsClientId=client)
            if not shapes:
                continue
            component = physx.PhysxRigidDynamicComponent()
            for shape in shapes:
                filename = shape[4].decode() if isinstance(shape[4], bytes) else str(shape[4])
                if shape[2] != p.GEOM_MESH or not os.path.isfile(filename):
                    raise RuntimeError(f"Panda link {link}: unsupported collision shape {shape}")
                collision = physx.PhysxCollisionShapeConvexMesh(
                    filename, np.asarray(shape[3], dtype=np.float32) * scale, material
                )
                collision.local_pose = to_sapien_pose(shape[5], shape[6])
                collision.contact_offset = world.config.contact_offset
                collision.rest_offset = 0.0
                component.attach(collision)
            component.kinematic = True
            entity = sapien.Entity()
            entity.name = f"panda_link_{link}"
            entity.add_component(component)
            if world.renders:
                visual = sapien.render.RenderBodyComponent()
                colour = sapien.render.RenderMaterial(base_color=[0.9, 0.9, 0.92, 1.0])
                for shape in shapes:
                    mesh = sapien.render.RenderShapeTriangleMesh(
                        shape[4].decode() if isinstance(shape[4], bytes) else str(shape[4]),
                        np.asarray(shape[3], dtype=np.float32),
                        colour,
                    )
                    mesh.local_pose = to_sapien_pose(shape[5], shape[6])
                    visual.attach(mesh)
                entity.add_component(visual)
            entity.set_pose(self._link_pose(link))
            world.scene.add_entity(entity)
            self.links.append((link, component, entity))

    def _link_pose(self, link: int) -> sapien.Pose:
        client, body = self.arm.client_id, self.arm.body_id
        if link < 0:
            position, quaternion = p.getBasePositionAndOrientation(body, physicsClientId=client)
        else:
            state = p.getLinkState(body, link, computeForwardKinematics=1, physicsClientId=client)
            position, quaternion = state[0], state[1]
        return to_sapien_pose(position, quaternion)

    def follow_model(self, drive: bool = False) -> None:
        """Place every mirrored link at the model's current link pose (see the module
        docstring for why they are teleported rather than given kinematic targets).

        ``drive`` (pushes): give them kinematic targets instead, reached at the end of the
        next step, so PhysX moves them with velocity, wakes what they touch and pushes it
        (a teleported link next to a sleeping block does not move it)."""
        for link, component, entity in self.links:
            if drive:
                component.set_kinematic_target(self._link_pose(link))
            else:
                entity.set_pose(self._link_pose(link))


class SapienKitchen3DRun(Kitchen3DRun):
    """One kitchen3d execution in SAPIEN (see the module docstring).

    Inherits the action semantics (``move``, ``pour``, ``follow``, ``step_n``, goal checks)
    from :class:`Kitchen3DRun` and replaces the world, stepping, carrying, measurements, and
    the pick/place steps that touch bodies.
    """

    def __init__(
        self,
        spec: SceneSpec,
        poses: dict[str, tuple[float, float]],
        seed: int,
        settings: ExecutionSettings,
        recorder_camera: Camera | None,
    ) -> None:
        self.spec = spec
        self.settings = settings
        self.rng = np.random.default_rng(seed)
        render_system = None
        #: Set when rendering is asked for but SAPIEN has no render device: the execution
        #: is then recorded and replayed on the CPU (see :mod:`.replay`).
        self._replay_camera: Camera | None = None
        if recorder_camera is not None:
            probe = probe_render_device()
            if probe.available:
                render_system = new_render_system()
                print("render: SAPIEN's renderer", file=sys.stderr)
            else:
                self._replay_camera = recorder_camera
                print(f"render: no SAPIEN render device ({probe.reason}); replaying the "
                      "recorded poses with PyBullet's TinyRenderer on the CPU", file=sys.stderr)
        # The kinematic model: never stepped, only posed (FK and distance queries).
        self.model = PhysicsWorld()
        self.world = SapienWorld(SapienWorldConfig(), render_system=render_system)  # type: ignore[assignment]
        try:
            self._build(spec, poses, settings)
        except BaseException:
            self.close()
            raise

    def _build(
        self,
        spec: SceneSpec,
        poses: dict[str, tuple[float, float]],
        settings: ExecutionSettings,
    ) -> None:
        """Scenery, kitchenware, beads and arms; settle; record the initial bead counts."""
        self.scene: KitchenScene = build_kitchen_scene(self.model.client, spec.n_arms, spec.table)
        self.table_z = float(self.scene.table.height)
        self._add_scenery()
        self.recorder = (
            FrameRecorder(self.world, settings.render_every, KITCHEN_VIEW,  # type: ignore[arg-type]
                          seconds_per_step=self.world.config.time_step)
            if self.world.renders  # type: ignore[attr-defined]
            else None
        )
        self.steps = 0
        self.log: list[dict[str, Any]] = []
        self.bodies: dict[str, SapienBody] = {}  # type: ignore[assignment]
        self.mirrors: dict[str, KitchenwareBody] = {}
        for name, obj in spec.objects.items():
            xy = obj.at if obj.fixed else poses.get(name)
            if xy is None:
                raise ActionFailed(f"object {name!r} has no initial AtPose")
            pose = pose_of(xy, self.table_z)
            geometry = obj.geometry()
            self.bodies[name] = create_kitchenware(
                self.world,  # type: ignore[arg-type]
                geometry,
                pose.position,
                pose.quaternion,
                object_material(obj.kind, self.rng, obj.fixed),
                body_type=("static" if obj.fixed else
                           "kinematic" if obj.kind in TOOL_KINDS else "dynamic"),
            )
            self.mirrors[name] = create_mirror(
                self.model.client, geometry, pose.position, pose.quaternion,
                BodyMaterial(mass=0.0), visual=False,
            )
        self.beads: dict[str, Beads] = {}  # type: ignore[assignment]
        for name, obj in spec.objects.items():
            if obj.contents is None:
                continue
            beads = BeadSpec(
                count=obj.contents.beads,
                radius=0.006,
                lateral_friction=float(np.clip(self.rng.normal(0.5, 0.1), 0.2, 0.8)),
                restitution=float(np.clip(self.rng.normal(0.7, 0.1), 0.4, 0.9)),
            )
            self.beads[obj.contents.material] = spawn_beads_in(
                self.world, self.bodies[name], beads, self.rng  # type: ignore[arg-type]
            )
        for arm in self.scene.arms:
            arm.set_configuration(np.asarray(PANDA_HOME))
        self.sapien_arms = [SapienArm(self.world, arm) for arm in self.scene.arms]  # type: ignore[arg-type]
        self.held: dict[int, tuple[str, Pose]] = {}
        self._init_records()  # tools are kinematic bodies here: nothing to pin
        self._grip_widths: dict[int, float] = {}
        if self._replay_camera is not None:
            self.recorder = ReplayRecorder(  # type: ignore[assignment]
                self._replay_scene(), self._snapshot, settings.render_every, self._replay_camera,
                seconds_per_step=self.world.config.time_step, follow=True,
            )
            self.recorder.caption = "initial state"
        self.step_n(self.world.steps_for(settings.settle_s))
        self.initial_counts = self.counts()

    def _add_scenery(self) -> None:
        """The model's table and pedestals as static SAPIEN boxes (floor: the ground)."""
        client = self.model.client
        material = physx_material(0.6, 0.0)
        for body in (self.scene.table_id, *self.scene.pedestal_ids):
            (shape,) = p.getCollisionShapeData(body, -1, physicsClientId=client)
            half = np.asarray(shape[3], dtype=np.float32) / 2.0  # boxes report full extents
            position, quaternion = p.getBasePositionAndOrientation(body, physicsClientId=client)
            component = physx.PhysxRigidStaticComponent()
            box = physx.PhysxCollisionShapeBox(half, material)
            box.local_pose = to_sapien_pose(shape[5], shape[6])
            component.attach(box)
            entity = sapien.Entity()
            entity.add_component(component)
            if self.world.renders:  # type: ignore[attr-defined]
                visual = sapien.render.RenderBodyComponent()
                visual.attach(sapien.render.RenderShapeBox(
                    half, sapien.render.RenderMaterial(base_color=[0.75, 0.6, 0.45, 1.0])))
                entity.add_component(visual)
            entity.set_pose(to_sapien_pose(position, quaternion))
            self.world.scene.add_entity(entity)  # type: ignore[attr-defined]

    def _replay_scene(self) -> ReplayScene:
        """What a CPU replay of this run must draw: arms, table, kitchenware, beads."""
        return ReplayScene(
            self.spec.n_arms,
            self.scene.table,
            {name: body.geometry for name, body in self.bodies.items()},
            {
                material: BeadGroup(len(beads), beads.spec.radius, bead_rgba(material, index))  # type: ignore[attr-defined]
                for index, (material, beads) in enumerate(self.beads.items())
            },
        )

    def _snapshot(self) -> ReplayFrame:
        """The state of every actor now: the model's arms (the SAPIEN links follow them),
        SAPIEN's kitchenware poses and bead positions."""
        return ReplayFrame(
            tuple((arm.get_configuration(), arm.finger_opening()) for arm in self.scene.arms),
            {name: body.pose() for name, body in self.bodies.items()},
            {material: beads.positions() for material, beads in self.beads.items()},  # type: ignore[attr-defined]
        )

    def close(self) -> None:
        self.world.close()
        self.model.close()

    # Simulation --------------------------------------------------------------------------

    def skill_physics(self, action: str) -> AbstractContextManager[None]:
        """No change: SAPIEN trials run every skill in one world config (the backend's,
        :class:`~.world.SapienWorldConfig` as shipped), the one this run builds; ``KeyError``
        for an action of no skill, as in PyBullet."""
        ACTION_SKILLS[action]
        return nullcontext()

    def _step(self) -> None:
        for arm in self.sapien_arms:
            arm.follow_model(self.driving)
        self.world.step()
        if self.recorder is not None:
            self.recorder(self.steps)
        self.steps += 1

    def _carry(self, arm_index: int, name: str, grasp: Pose, nxt: Pose | None) -> None:
        # The arm's mirrored links reach the model's current pose during the next step; the
        # held object is targeted at the same instant (``nxt`` is the pose one step later).
        tool = self.scene.arms[arm_index].end_effector_pose() @ grasp
        self.bodies[name].move_to(tool.position, tool.quaternion)  # type: ignore[attr-defined]

    # Measurements ------------------------------------------------------------------------

    def counts(self) -> dict[str, dict[str, int]]:
        """Beads of each material contained in each cup/bowl."""
        containers = {
            n: b for n, b in self.bodies.items() if self.spec.objects[n].kind in ("cup", "bowl")
        }
        out: dict[str, dict[str, int]] = {}
        for material, beads in self.beads.items():
            positions = beads.positions()  # type: ignore[attr-defined]
            out[material] = {
                n: int(contained_mask(b, positions).sum())  # type: ignore[arg-type]
                for n, b in containers.items()
            }
            out[material]["total"] = len(beads)
            out[material]["off_table"] = count_lost(positions, floor_z=self.table_z - 0.05)
        return out

    def object_xy(self, name: str) -> tuple[float, float]:
        position, _ = self.bodies[name].pose()
        return float(position[0]), float(position[1])

    def material_positions(self, material: str) -> np.ndarray:
        return self.beads[material].positions()  # type: ignore[attr-defined, no-any-return]

    def inside(self, name: str, positions: np.ndarray) -> np.ndarray:
        return contained_mask(self.bodies[name], positions)  # type: ignore[arg-type]

    def finger_gaps(self, arm_index: int, name: str) -> list[float]:
        """Distances (m) from each finger to the object, in the kinematic model with the
        object placed where SAPIEN has it."""
        arm = self.scene.arms[arm_index]
        mirror = self.mirrors[name]
        mirror.set_pose(*self.bodies[name].pose())
        gaps = []
        for link in PANDA_FINGER_JOINTS:
            points = p.getClosestPoints(
                arm.body_id, mirror.body, 0.05, linkIndexA=link, physicsClientId=self.model.client
            )
            gaps.append(min((c[8] for c in points), default=1.0))
        return gaps

    # Actions -----------------------------------------------------------------------------

    def _preshape(self, arm_index: int, width: float) -> None:
        opening = min(2.0 * PANDA_FINGER_TRAVEL, width + 2.0 * PRESHAPE_CLEARANCE_M)
        self.scene.arms[arm_index].set_finger_opening(opening)

    def pick(self, name: str, grasp: Any, path: Any) -> None:
        arm = self.scene.arms[path.arm]
        width = object_grasps(self.spec.objects[name], self.spec.n_arms)[int(grasp[1])].width
        self._preshape(path.arm, width)
        # Closed-loop, as in PyBullet: the approach moves with the object if it stands off.
        path = ArmPath(path.arm, self.perceived_approach(name, grasp, path), path.kind,
                       path.held, path.touching, path.target)
        self.follow(path.arm, path.configurations, self.settings.free_speed / 2)
        arm.set_finger_opening(max(width - 0.002, 0.0))
        gaps = self.finger_gaps(path.arm, name)
        if max(gaps) > FINGER_CONTACT_M:
            raise ActionFailed(f"pick {name}: fingers {np.round(gaps, 4).tolist()} m from it")
        self.bodies[name].set_kinematic(True)  # type: ignore[attr-defined]
        self.held[path.arm] = (name, self.grasp_pose(name, grasp))
        self._grip_widths[path.arm] = width
        self.follow(path.arm, path.configurations[::-1], self.settings.free_speed / 2)
        self.log.append({"action": "pick", "object": name, "finger_gaps_m": gaps})

    def place(self, name: str, xy: tuple[float, float], path: Any) -> None:
        self.follow(path.arm, path.configurations, self.settings.free_speed / 2)
        del self.held[path.arm]
        self._preshape(path.arm, self._grip_widths.pop(path.arm))
        if self.spec.objects[name].kind not in TOOL_KINDS:  # tools stay kinematic at rest
            self.bodies[name].set_kinematic(False)  # type: ignore[attr-defined]
        self.follow(path.arm, path.configurations[::-1], self.settings.free_speed / 2)
        self.step_n(self.world.steps_for(self.settings.settle_s))
        rest = self.object_xy(name)
        error = float(np.hypot(rest[0] - xy[0], rest[1] - xy[1]))
        self.log.append({"action": "place", "object": name, "error_m": error})
        if error > PLACE_TOLERANCE_M:
            raise ActionFailed(f"place {name}: came to rest {error:.3f} m from its pose")


class SapienKitchen3DExecutor(Kitchen3DExecutor):
    """:class:`~ltamp_cli.backends.execution.PlanExecutor` for kitchen3d plans in SAPIEN.

    ``render_path`` uses SAPIEN's renderer when a rendering device exists and otherwise
    replays the recorded execution with PyBullet's TinyRenderer (:mod:`.replay`); one
    line on stderr says which.
    """

    run_class = SapienKitchen3DRun

    def execute(
        self, problem: Any, plan_result: Any, seed: int, render_path: Any = None
    ) -> Any:
        report = super().execute(problem, plan_result, seed, render_path)
        report.details["backend"] = "sapien"
        return report


__all__ = ["SapienArm", "SapienKitchen3DExecutor", "SapienKitchen3DRun", "object_material"]
