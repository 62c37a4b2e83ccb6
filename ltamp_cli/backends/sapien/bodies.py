"""SAPIEN bodies built from the backend-independent kitchenware geometry, and beads.

Each convex piece of a :class:`~ltamp_cli.backends.kitchenware_geometry.KitchenwareGeometry`
becomes one ``PhysxCollisionShapeConvexMesh`` made directly from its vertices (PhysX takes
their convex hull), all attached to one rigid component, so a concave bowl collides as the
union of its convex parts, exactly as in the PyBullet backend. Visual shapes are added only
when the world has a render system. No files are written.

Bodies are ``"static"`` (fixed kitchenware), ``"kinematic"`` (a tool moved along a path:
PhysX derives its velocity from successive targets, so contacts push beads),
``"dynamic"``, or ``"placed"``: a dynamic body with its material's mass that its owner puts
at a pose, with a velocity, before every step (:meth:`SapienBody.place`), as PyBullet moves
every tool. What the solver does to a placed body during a step (beads pushing it) is
discarded by the next placement, so loads sink into it as into PyBullet's tools.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.spatial.transform import Rotation

from ltamp_cli.backends.kitchenware_geometry import KitchenwareGeometry
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial
from ltamp_cli.backends.pybullet.particles import BeadSpec, bead_layout
from ltamp_cli.backends.sapien.world import (
    GRAVITY_M_S2,
    SapienWorld,
    from_sapien_pose,
    physx,
    sapien,
    to_sapien_pose,
)

BodyType = Literal["static", "kinematic", "dynamic", "placed"]
IDENTITY_QUAT = (0.0, 0.0, 0.0, 1.0)


@dataclass(frozen=True, eq=False)
class SapienBody:
    """A created kitchenware body: its entity, rigid component and geometry."""

    entity: sapien.Entity
    component: physx.PhysxRigidBaseComponent
    geometry: KitchenwareGeometry
    body_type: BodyType

    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Position ``(3,)`` m and quaternion ``(4,)`` xyzw of the object frame."""
        return from_sapien_pose(self.entity.pose)

    def set_pose(
        self, position: Sequence[float] | np.ndarray, orientation: Sequence[float] = IDENTITY_QUAT
    ) -> None:
        """Teleport the object frame (no velocity): for placing, not for moving tools."""
        pose = to_sapien_pose(position, orientation)
        self.entity.set_pose(pose)
        if self.is_kinematic:
            # Otherwise a stale target would drag the body back on the next step.
            self.component.set_kinematic_target(pose)  # type: ignore[attr-defined]

    def place(
        self, position: Sequence[float] | np.ndarray, orientation: Sequence[float] | np.ndarray,
        linear_velocity: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
        angular_velocity: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
    ) -> None:
        """Put a placed body's object frame at ``position`` ``(3,)`` m with ``orientation``
        ``(4,)`` xyzw, moving with ``linear_velocity`` ``(3,)`` m/s (of the object-frame
        origin) and ``angular_velocity`` ``(3,)`` rad/s, world frame (placed bodies only)."""
        if self.body_type != "placed":
            raise ValueError(f"only placed bodies are placed, not a {self.body_type} one")
        component = self.component
        self.entity.set_pose(to_sapien_pose(position, orientation))
        lever = Rotation.from_quat(np.asarray(orientation, dtype=float)).apply(
            np.asarray(component.cmass_local_pose.p, dtype=float))  # type: ignore[attr-defined]
        omega = np.asarray(angular_velocity, dtype=float)
        component.linear_velocity = (  # type: ignore[attr-defined]
            np.asarray(linear_velocity, dtype=float) + np.cross(omega, lever)
        ).astype(np.float32)
        component.angular_velocity = omega.astype(np.float32)  # type: ignore[attr-defined]

    @property
    def is_kinematic(self) -> bool:
        return bool(getattr(self.component, "kinematic", False))

    def move_to(
        self, position: Sequence[float] | np.ndarray, orientation: Sequence[float] = IDENTITY_QUAT
    ) -> None:
        """Reach this pose at the end of the next step, with the velocity that implies
        (kinematic bodies only)."""
        if not self.is_kinematic:
            raise ValueError(f"only kinematic bodies move to targets, not a {self.body_type} one")
        self.component.set_kinematic_target(  # type: ignore[attr-defined]
            to_sapien_pose(position, orientation)
        )

    def set_kinematic(self, kinematic: bool) -> None:
        """Switch a non-static body between carried (kinematic) and free (dynamic, at rest):
        how a grasped object is held and released."""
        if self.body_type == "static":
            raise ValueError("a static body cannot be picked up")
        component = self.component
        component.kinematic = bool(kinematic)  # type: ignore[attr-defined]
        if kinematic:
            component.set_kinematic_target(self.entity.pose)  # type: ignore[attr-defined]
        else:
            component.linear_velocity = np.zeros(3)  # type: ignore[attr-defined]
            component.angular_velocity = np.zeros(3)  # type: ignore[attr-defined]


def physx_material(
    friction: float, restitution: float, friction_scale: float = 1.0
) -> physx.PhysxMaterial:
    """A PhysX material whose contacts behave like Bullet's for the same coefficients.

    Bullet combines two bodies' friction and restitution by *multiplying* them, PhysX by
    *averaging*. Storing squares makes PhysX's average ``(a² + b²) / 2`` equal Bullet's
    product ``ab`` when ``a = b`` (bead on bead) and exceed it by only ``(a - b)² / 2``
    otherwise. ``friction_scale`` then corrects for the solvers themselves (beads only, see
    :class:`~.world.SapienWorldConfig`).
    """
    mu = float(friction) ** 2 * float(friction_scale)
    return physx.PhysxMaterial(mu, mu, float(restitution) ** 2)


def _material(material: BodyMaterial, friction_scale: float) -> physx.PhysxMaterial:
    return physx_material(material.lateral_friction, material.restitution, friction_scale)


def _visuals(geometry: KitchenwareGeometry, rgba: Sequence[float]) -> sapien.Component:
    render = sapien.render
    body = render.RenderBodyComponent()
    colour = render.RenderMaterial(base_color=[float(c) for c in rgba])
    for hull in geometry.hulls():
        vertices = np.asarray(hull.vertices, dtype=np.float32)
        body.attach(
            render.RenderShapeTriangleMesh(
                vertices,
                np.asarray(hull.faces, dtype=np.uint32),
                np.asarray(hull.vertex_normals, dtype=np.float32),
                np.zeros((len(vertices), 2), dtype=np.float32),
                colour,
            )
        )
    return body


def create_kitchenware(
    world: SapienWorld,
    geometry: KitchenwareGeometry,
    position: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
    orientation: Sequence[float] = IDENTITY_QUAT,
    material: BodyMaterial | None = None,
    body_type: BodyType = "static",
) -> SapienBody:
    """Add ``geometry`` to ``world`` as one body at the given object-frame pose.

    A dynamic or placed body weighs ``material.mass`` kg (uniform density over the pieces);
    static and kinematic bodies ignore the mass.
    """
    material = material or BodyMaterial()
    config = world.config
    component: physx.PhysxRigidBaseComponent
    if body_type == "static":
        component = physx.PhysxRigidStaticComponent()
    else:
        component = physx.PhysxRigidDynamicComponent()
    # A spoon carried as a tool gets SapienWorldConfig.spoon_friction_scale (the beads'
    # solver correction, bead_friction_scale, applied to bead-on-spoon contacts too).
    tool_spoon = geometry.kind == "spoon" and body_type in ("kinematic", "placed")
    physical = _material(material, config.spoon_friction_scale if tool_spoon else 1.0)
    density = 1000.0
    if body_type in ("dynamic", "placed"):
        if material.mass <= 0:
            raise ValueError(f"a {body_type} body needs a positive mass")
        density = material.mass / geometry.volume()
    scale = np.ones(3, dtype=np.float32)
    # Beads rest slightly inside a spoon held as a tool, as in PyBullet (see
    # SapienWorldConfig.spoon_rest_offset and placed_spoon_rest_offset); every other body's
    # surface is exact.
    rest_offset = 0.0
    if geometry.kind == "spoon" and body_type == "kinematic":
        rest_offset = config.spoon_rest_offset
    elif geometry.kind == "spoon" and body_type == "placed":
        rest_offset = config.placed_spoon_rest_offset
    for piece in geometry.pieces:
        shape = physx.PhysxCollisionShapeConvexMesh(
            np.asarray(piece, dtype=np.float32), scale, physical
        )
        shape.density = density
        shape.contact_offset = config.contact_offset
        shape.rest_offset = rest_offset
        component.attach(shape)
    if isinstance(component, physx.PhysxRigidDynamicComponent):
        component.kinematic = body_type == "kinematic"
        component.linear_damping = material.linear_damping
        component.angular_damping = material.angular_damping
        component.solver_position_iterations = config.solver_position_iterations
        component.solver_velocity_iterations = config.solver_velocity_iterations
    entity = sapien.Entity()
    entity.name = geometry.kind
    entity.add_component(component)
    if world.renders:
        entity.add_component(_visuals(geometry, material.rgba))
    entity.set_pose(to_sapien_pose(position, orientation))
    world.scene.add_entity(entity)
    return SapienBody(entity, component, geometry, body_type)


@dataclass(frozen=True, eq=False)
class Beads:
    """The beads of one trial: one dynamic sphere per bead."""

    components: tuple[physx.PhysxRigidDynamicComponent, ...]
    spec: BeadSpec

    def __len__(self) -> int:
        return len(self.components)

    def positions(self) -> np.ndarray:
        """World positions ``(n, 3)`` of the bead centres, metres."""
        if not self.components:
            return np.zeros((0, 3))
        return np.array([c.entity_pose.p for c in self.components], dtype=float)


def rolling_damping(spec: BeadSpec, match_speed: float | None) -> float:
    """Extra angular damping (1/s) standing in for Bullet's rolling friction of ``spec``'s
    beads, which PhysX lacks (``0`` when ``match_speed`` is ``None``).

    Bullet caps the rolling torque of a contact at ``μ_r N``, with the pair's rolling
    coefficient combined as ``μ_r = r_a μ_b + r_b μ_a`` (``r``: rolling, ``μ``: lateral
    friction); bead on bead that is ``2 r μ`` metres (the kitchenware has none). A solid
    sphere of radius ``R`` rolling under its weight then slows at a constant
    ``a = 5 μ_r g / (7 R)`` m/s². Angular damping ``c`` slows the same rolling sphere at
    ``a = (2/7) c v`` (only its spin is damped, and the spin carries ``2/7`` of the rolling
    inertia about the contact point), so ``c = 5 μ_r g / (2 R v)`` matches Bullet exactly at
    the speed ``v = match_speed`` (m/s) and damps slower beads less than Bullet does
    (viscous, not Coulomb). In flight a sphere's spin changes nothing else, so the term
    acts through contacts only, as rolling friction does. The pour's beads (``r = 0.001``
    m, 6 mm) get ~80 1/s at 0.05 m/s: they barely roll, as in Bullet; the scoop's
    (``r = 1e-5``) get < 1 1/s.
    """
    if match_speed is None:
        return 0.0
    mu_rolling = 2.0 * spec.rolling_friction * spec.lateral_friction
    return 5.0 * mu_rolling * GRAVITY_M_S2 / (2.0 * spec.radius * match_speed)


def spawn_beads(world: SapienWorld, spec: BeadSpec, positions_world: np.ndarray) -> Beads:
    """Add one dynamic sphere per row of ``positions_world`` ``(n, 3)``."""
    config = world.config
    physical = physx_material(
        spec.lateral_friction, spec.restitution, config.bead_friction_scale
    )
    visual_material = sapien.render.RenderMaterial(base_color=list(spec.rgba)) if (
        world.renders
    ) else None
    components = []
    for position in np.asarray(positions_world, dtype=float).reshape(-1, 3):
        component = physx.PhysxRigidDynamicComponent()
        shape = physx.PhysxCollisionShapeSphere(float(spec.radius), physical)
        shape.contact_offset = config.contact_offset
        shape.rest_offset = 0.0
        component.attach(shape)
        component.mass = float(spec.mass)
        component.linear_damping = float(spec.damping)
        component.angular_damping = float(spec.damping) + rolling_damping(
            spec, config.rolling_match_speed
        )
        component.solver_position_iterations = config.solver_position_iterations
        component.solver_velocity_iterations = config.solver_velocity_iterations
        component.max_angular_velocity = config.bead_max_angular_velocity
        component.sleep_threshold = config.bead_sleep_threshold
        entity = sapien.Entity()
        entity.name = "bead"
        entity.add_component(component)
        if visual_material is not None:
            visual = sapien.render.RenderBodyComponent()
            visual.attach(sapien.render.RenderShapeSphere(float(spec.radius), visual_material))
            entity.add_component(visual)
        entity.set_pose(sapien.Pose(position.astype(np.float32)))
        world.scene.add_entity(entity)
        components.append(component)
    return Beads(tuple(components), spec)


def world_to_object(
    points: np.ndarray, position: np.ndarray, orientation: np.ndarray
) -> np.ndarray:
    """Express world points ``(n, 3)`` in the frame at ``position`` ``(3,)`` with quaternion
    ``orientation`` ``(4,)`` xyzw."""
    rotation = Rotation.from_quat(orientation).as_matrix()
    return (np.asarray(points, dtype=float).reshape(-1, 3) - np.asarray(position)) @ rotation


def object_to_world(
    points: np.ndarray, position: np.ndarray, orientation: np.ndarray
) -> np.ndarray:
    """Inverse of :func:`world_to_object`: object-frame points ``(n, 3)`` in the world."""
    rotation = Rotation.from_quat(orientation).as_matrix()
    return np.asarray(points, dtype=float).reshape(-1, 3) @ rotation.T + np.asarray(position)


def contained_mask(container: SapienBody, positions_world: np.ndarray) -> np.ndarray:
    """Bool mask ``(n,)``: which bead centres lie in ``container``'s containment prism."""
    prism = container.geometry.cavity
    if prism is None:
        raise ValueError(f"a {container.geometry.kind} has no cavity to contain beads")
    position, orientation = container.pose()
    return prism.contains(world_to_object(positions_world, position, orientation))


def spawn_beads_in(
    world: SapienWorld, container: SapienBody, spec: BeadSpec, rng: np.random.Generator
) -> Beads:
    """Spawn up to ``spec.count`` beads inside ``container`` (a vessel) at its current pose,
    on the same jittered grid (and the same draws from ``rng``) as the PyBullet backend."""
    dims = container.geometry.vessel
    if dims is None:
        raise ValueError(f"a {container.geometry.kind} is not a vessel: cannot hold beads")
    local = bead_layout(dims, spec, rng)
    position, orientation = container.pose()
    return spawn_beads(world, spec, object_to_world(local, position, orientation))
