"""A Panda in the loop of a Kitchen3D trial: the tool is grasped and carried by the arm.

:class:`RobotTrialPhysics` implements :class:`~ltamp_cli.backends.skills3d.physics.TrialPhysics`
like :class:`~.physics.BulletTrialPhysics`, except that the *tool* is not moved kinematically:

1. When the tool body is added (:meth:`RobotTrialPhysics.add_body` with role ``"tool"``
   at the first pose of ``preview``, the skill's untimed tool path), a fixed-base Panda is
   loaded on the table ``settings.base_distance`` m from the tool's start (the push: from
   the middle of its path) at the skill's bearings (pour, push, stir: ``-y`` then ``+y``;
   scoop: ``+y``, ``+x``, ``-x``), facing it. The tool's grasps (:func:`tool_grasps`: a cup's
   side grasps when it fits the 8 cm gripper, then rim grasps pinching its wall from above;
   the spoon's handle; the push's pad held as the closed fingertips; the stirrer rod) are
   ranked per base (palm not facing the base, hand nearest the base first) and the first
   ``max_grasps`` are tried: the whole path is solved by
   :func:`~..robot.cartesian.follow_tool_path` (verified IK, joint continuity, collision
   checks against the table, the fixed bowl and the held tool), the first grasp and base
   that carry it out win. No solution: :class:`RobotFailure` ``"reach"``; only colliding
   ones: ``"collision"``; no grasp fits the gripper: ``"grasp"``. Failing here costs no
   bead simulation. A tool added elsewhere (the scoop's spoon-capacity measurement) is not
   grasped and moves free-floating.
2. The tool is held by a fixed constraint from the hand whose force is limited to
   ``settings.grasp_force`` newtons, so a heavy or shaken tool can slip out of the grasp.
3. :meth:`follow` drives the joints by position control along the solved configurations,
   one target per step of the skill's own timed path (:func:`skill_timed_configurations`:
   the arm keeps the skill's speeds), or (``skill_timing=False``) timed by a rest-to-rest
   trapezoid over the path's joint-space length
   (:func:`~ltamp_cli.motion.timing.trapezoid_fraction`: every joint's speed stays below
   ``joint_speed`` rad/s); :meth:`hold` keeps commanding the current configuration.
4. After every simulated step the trial fails with :class:`RobotFailure` when the arm (any
   link but its fixed base) touches the table or the bowl, a link other than the hand touches
   the tool, any arm link touches a free body (the manipulated object: the pushed block,
   the stirred cup) (``"collision"``), or the tool is more than ``slip_position_m`` /
   ``slip_angle_rad`` from where the grasp should hold it (``"slip"``).

Why a hand touching the manipulated object fails the trial, and why the push's hand leans
back (issue #20; setup versions push 3, stir 4): the skill's control names the contact —
the push's fingertip pad at ``contact_height`` and ``lateral_offset`` — and the free-floating
trial simulates exactly that contact. Held straight down, the Panda's palm (link 8, ~6 cm
deep, ~20 cm wide) sits ~3.45 cm above the pad's centre, so on blocks taller than that
above the contact (129 of the fidelity bench's 600 push inputs) the palm pushed the block
(on 95 of them the pad never touched it) and pushed it straight where the 2 cm pad alone
turns it: a different, unplanned contact that made 12 robot-only "successes". A roboticist
holds a pusher so that the hand stays clear of the object and counts an unplanned
arm-object contact as a collision, which issue #20 counts as a failure; the reference push
(LTAMP's ``sample_push_contact``) likewise backs the gripper off until none of its links
collides with the block and tilts the gripper by up to π/4. So the pad is held with the
hand leaning back by ``push_pitch`` = π/4 (the palm stays behind and above the block's
face on a straight push), and an arm link touching the block is a ``"collision"`` failure:
on those 600 inputs the hand then touched the block only after the pad, as an off-centre
push turned it into the leaning hand, and only on inputs the free pad fails too (label
agreement 0.968 → 0.980, ``docs/results/push/README.md``).

The backend turns a :class:`RobotFailure` into the skill's failure score (a valid trial:
the control was executed and failed). Units: metres, radians, seconds, newtons.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

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
from ltamp_cli.backends.pybullet.robot.cartesian import (
    CartesianConfig,
    densify_tool_path,
    follow_tool_path,
)
from ltamp_cli.backends.pybullet.robot.collision import ArmCollisionChecker, AttachedBody
from ltamp_cli.backends.pybullet.robot.grasps import (
    MAX_GRASP_WIDTH,
    Grasp,
    bar_grasps,
    box_top_grasps,
    cylinder_side_grasps,
    rim_grasps,
)
from ltamp_cli.backends.pybullet.robot.pose import Pose, rotation_distance
from ltamp_cli.backends.pybullet.skills.physics import BulletTrialPhysics
from ltamp_cli.backends.skills3d.physics import IDENTITY_QUAT, BodyRole, SimBody, StepCallback
from ltamp_cli.motion.timing import trapezoid_duration, trapezoid_fraction

#: Values of the ``robot`` trial setting: ``none`` (free-floating tool) or ``panda``.
ROBOTS = ("none", "panda")
#: Version of the robot trial setup (grasps, base placement, timing) per skill: part of the
#: fidelity bench's cache keys of robot trials. 1: side grasps only, trapezoidal timing
#: (pour only); 2: rim grasps straight down, per-skill base bearings, the skill's own
#: timing, every skill; 3 (pour): rim grasps leaning out by π/4; 3 (stir): the planner's
#: collision check places the held tool at its centre of mass (it was displaced by the
#: kitchenware's com_offset: the stirrer rod 10 cm into the table, a cup or spoon ~2 mm);
#: 3 (push) / 4 (stir): an arm link touching a free body (the pushed block, the stirred
#: cup) is a collision, and the push's hand leans back by π/4 (the palm pushed tall blocks).
ROBOT_SETUP_VERSIONS: Mapping[str, int] = MappingProxyType(
    {"pour": 3, "scoop": 2, "push": 3, "stir": 4})
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
    ``base_distance`` (m): horizontal distance from the tool's start position (the path's
    middle for a push) to the arm's base; ``base_bearings``: where the base stands around it
    (radians about ``z`` from ``+x``: ``-π/2`` at ``-y``, ``0`` at ``+x``), tried in turn
    until the path is solved (``None``: the skill's :data:`SKILL_BEARINGS`).
    ``grasp_heights``: fractions of the cup's height tried for the side grasp, the first
    whose outer diameter fits the gripper wins; ``rim_grasps``: also pinch the cup's wall at
    its rim from above (any cup diameter; the reference LTAMP code grasps cups by their
    side, top or edge), the hand leaning out by each of ``rim_leans`` (radians; π/4: on
    5 bench pours that collided with the hand straight down, 3 were carried out, as with
    1.1 rad; with (π/4, 0) 2). ``push_pitch`` (rad): how far the hand holding the push's
    fingertip pad leans back from vertical (π/4, the default and the reference's largest
    gripper tilt: the palm stays behind the block's face; ``0``, straight down, puts the
    palm ~3.45 cm above the pad's centre, where it touches blocks taller than that above
    the contact: 129 of the fidelity bench's 600 push inputs, now collisions).
    ``max_grasps``: grasps tried per base bearing (those whose hand
    is nearest the base, its palm not facing the base). ``skill_timing``: the arm follows
    the skill's own timing of the tool path (its speeds; ``False``: a rest-to-rest
    trapezoid over the joint path limited by ``joint_speed`` rad/s and
    ``joint_acceleration`` rad/s²). ``position_gain``:
    PyBullet's joint position-control gain. ``slip_position_m`` / ``slip_angle_rad``: how far
    the tool may drift from the grasp before the trial counts as slipped.
    ``contact_tolerance_m``: penetration depth an arm contact needs to count (0: any
    touch). ``plan_collisions``: check the solved path for collisions before simulating
    (``False``: only the contacts met while simulating fail the trial).
    """

    grasp_force: float = 200.0
    base_distance: float = 0.5
    base_bearings: tuple[float, ...] | None = None
    grasp_heights: tuple[float, ...] = (0.45, 0.3, 0.15)
    rim_grasps: bool = True
    rim_leans: tuple[float, ...] = (np.pi / 4,)
    push_pitch: float = np.pi / 4
    max_grasps: int = 6
    skill_timing: bool = True
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
        if self.max_grasps < 1:
            raise ValueError("max_grasps must be >= 1")
        if not 0.0 <= self.push_pitch < np.pi / 2:
            raise ValueError("push_pitch must be in [0, π/2)")
        if self.base_bearings is not None and not self.base_bearings:
            raise ValueError("base_bearings must name at least one bearing (or be None)")


def cup_grasps(geometry: KitchenwareGeometry, heights: Sequence[float],
               leans: Sequence[float] = (0.0,)) -> tuple[Grasp, ...]:
    """Grasps of a vessel (base centre at its origin): side grasps approaching along ``±x``
    and ``±y`` (hand upright and flipped) at the first fraction of ``heights`` where the
    outer diameter fits the gripper (none for a wider cup), then, for each of ``leans``
    (radians), grasps pinching the wall at the rim from above at 8 points around it
    (:func:`~..robot.grasps.rim_grasps`)."""
    dims = geometry.vessel
    if dims is None:
        raise RobotFailure("grasp", f"a {geometry.kind} has no side grasp")
    grasps: tuple[Grasp, ...] = ()
    for fraction in heights:
        radius = float(dims.outer_radius_at(dims.height * fraction))
        if 2.0 * radius > MAX_GRASP_WIDTH - 0.002:
            continue
        grasps = cylinder_side_grasps(radius, dims.height, base_z=0.0, grasp_height=fraction,
                                      n_yaw=4)
        break
    for lean in leans:
        if dims.thickness / np.cos(lean) < MAX_GRASP_WIDTH:
            grasps += rim_grasps(dims.top_radius, dims.height, dims.thickness, lean=lean)
    return grasps


def spoon_grasps(geometry: KitchenwareGeometry, along: float = 0.75) -> tuple[Grasp, ...]:
    """Grasps of a spoon's handle (its last piece, a thin box) ``along`` its length from
    the head: :func:`~..robot.grasps.bar_grasps` (fingers across the 4 mm thickness or the
    12 mm width, from either side)."""
    handle = geometry.pieces[-1]
    centre = handle.mean(axis=0)
    # The box's axes from its 8 corners: principal directions of the centred vertices.
    _, _, rows = np.linalg.svd(handle - centre)
    axes = rows.T
    half = np.abs((handle - centre) @ axes).max(axis=0)
    long = int(np.argmax(half))
    # The handle leaves the head towards +y: its axis pointing away from the head.
    direction = axes[:, long] * (1.0 if axes[1, long] >= 0 else -1.0)
    point = centre + direction * half[long] * (2.0 * along - 1.0)
    return bar_grasps(point, axes, half)


def tool_grasps(geometry: KitchenwareGeometry, settings: RobotSettings) -> tuple[Grasp, ...]:
    """The grasps tried for a tool, by its kind: a cup (:func:`cup_grasps`), a spoon's
    handle (:func:`spoon_grasps`), the push's fingertip pad (from above, the closed
    fingertips at the pad: the pad is their contact shape, the finger meshes do not touch
    the pushed block) or a stirrer rod (side grasps 85 % up it)."""
    if geometry.kind == "cup":
        return cup_grasps(geometry, settings.grasp_heights,
                          settings.rim_leans if settings.rim_grasps else ())
    if geometry.kind == "spoon":
        return spoon_grasps(geometry)
    points = np.concatenate(geometry.pieces)
    low, high = points.min(axis=0), points.max(axis=0)
    if geometry.kind == "pusher":
        # The pad stands in for the closed fingertips: held from above, fingers closed on
        # it (kind "fingertips", see RobotTrialPhysics._attach), the hand leaning back by
        # settings.push_pitch.
        return tuple(Grasp("fingertips", grasp.tool_in_gripper, 0.0)
                     for grasp in box_top_grasps((high - low) / 2.0, settings.push_pitch))
    if geometry.kind == "stirrer":
        radius = float(max(high[0] - low[0], high[1] - low[1]) / 2.0)
        return cylinder_side_grasps(radius, float(high[2] - low[2]), base_z=float(low[2]),
                                    grasp_height=0.85, n_yaw=4)
    raise RobotFailure("grasp", f"no grasp for a {geometry.kind}")


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


def path_progress(preview: PosePath, timed: PosePath) -> np.ndarray:
    """Where each pose of ``timed`` ``(m, ·)`` lies along ``preview`` ``(n, ·)``, as a
    fractional waypoint index ``(m,)`` in ``[0, n - 1]``.

    ``timed`` must be ``preview`` resampled segment by segment, each pose interpolated
    between two consecutive waypoints with one fraction for position and rotation (as
    :func:`~..paths.timed_poses` does): the fraction is recovered from the position
    (from the rotation on a segment that only turns)."""
    rotations = preview.rotations()
    timed_rotations = timed.rotations()
    last = len(preview) - 1
    progress = np.zeros(len(timed))
    segment = 0
    for j in range(len(timed)):
        if last == 0:
            continue
        # A segment's samples end at its last waypoint; the next pose is on the next one.
        if j > 0 and progress[j - 1] >= segment + 1.0 - 1e-9 and segment < last - 1:
            segment += 1
        a, b = preview.positions[segment], preview.positions[segment + 1]
        shift = b - a
        turn = float((rotations[segment].inv() * rotations[segment + 1]).magnitude())
        if float(shift @ shift) > 1e-18:
            fraction = float((timed.positions[j] - a) @ shift / (shift @ shift))
        elif turn > 1e-12:
            fraction = float((rotations[segment].inv() * timed_rotations[j]).magnitude()
                             / turn)
        else:
            fraction = 1.0
        fraction = min(max(fraction, 0.0), 1.0)
        progress[j] = segment + fraction
    return progress


def skill_timed_configurations(configurations: np.ndarray, preview: PosePath,
                               timed: PosePath, cartesian: CartesianConfig) -> np.ndarray:
    """Joint targets ``(m, 7)``, one per pose of the skill's ``timed`` tool path: the
    solved ``configurations`` ``(n, 7)`` (one per pose of ``preview`` densified with
    ``cartesian``'s step limits) interpolated at each timed pose's place along the path
    (:func:`path_progress`), so the arm keeps the skill's speeds."""
    q = np.asarray(configurations, dtype=float)
    counts = [len(densify_tool_path([Pose(preview.positions[i], preview.quaternions[i]),
                                     Pose(preview.positions[i + 1], preview.quaternions[i + 1])],
                                    cartesian.max_translation, cartesian.max_rotation)) - 1
              for i in range(len(preview) - 1)]
    offsets = np.concatenate([[0.0], np.cumsum(counts)]).astype(float)
    if int(offsets[-1]) + 1 != len(q):
        raise ValueError(f"{len(q)} configurations do not match the densified preview "
                         f"({int(offsets[-1]) + 1} poses)")
    progress = path_progress(preview, timed)
    segment = np.minimum(np.floor(progress).astype(int), max(len(counts) - 1, 0))
    if counts:
        index = offsets[segment] + (progress - segment) * np.asarray(counts)[segment]
    else:
        index = np.zeros(len(progress))
    grid = np.arange(len(q), dtype=float)
    return np.stack([np.interp(index, grid, q[:, j]) for j in range(q.shape[1])], axis=1)


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
    free: list[KitchenwareBody] = field(default_factory=list)
    command: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class RobotTrialPhysics(BulletTrialPhysics):
    """Trial physics with the tool in a Panda's hand (see the module docstring).

    ``preview`` is the skill's untimed tool path (the same poses :meth:`follow` will be
    given, before timing); ``seed`` seeds the IK restarts. ``bearings``: where the base
    stands (see :class:`RobotSettings`; the settings' ``base_bearings`` win when given);
    ``anchor``: ``"start"`` (the base stands ``base_distance`` from the tool's start) or
    ``"middle"`` (from the middle of the path's horizontal extent). A tool added anywhere but
    the preview's first pose (the scoop's spoon-capacity measurement, which no robot runs)
    is not grasped: it moves free-floating as in :class:`BulletTrialPhysics`. One instance
    runs one trial.
    """

    preview: PosePath | None = None
    settings: RobotSettings = field(default_factory=RobotSettings)
    seed: int = 0
    bearings: tuple[float, ...] = (-np.pi / 2, np.pi / 2)
    anchor: str = "start"
    state: RobotState = field(default_factory=RobotState, init=False)

    def __post_init__(self) -> None:
        if self.anchor not in ("start", "middle"):
            raise ValueError(f"anchor must be 'start' or 'middle', got {self.anchor!r}")

    def reset(self) -> None:
        super().reset()
        self.state.arm = self.state.plan = self.state.tool = self.state.command = None
        self.state.obstacles = [self.world.table]
        self.state.free = []

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
        elif role == "free":
            self.state.free.append(body)
        elif role == "tool" and self._at_preview_start(position, quaternion):
            if self.state.tool is not None:
                raise ValueError("the Panda holds one tool per trial")
            self.state.tool = body
            self._grasp(body, Pose(np.asarray(position), np.asarray(quaternion)))
        return body

    def _at_preview_start(self, position: Sequence[float] | np.ndarray,
                          quaternion: Sequence[float] | np.ndarray) -> bool:
        if self.preview is None:
            raise ValueError("a robot trial needs the tool's path (preview) before the tool")
        start_q = np.asarray(self.preview.quaternions[0], dtype=float)
        return bool(np.linalg.norm(np.asarray(position, dtype=float)
                                   - self.preview.positions[0]) < 1e-9
                    and abs(abs(float(np.dot(np.asarray(quaternion, dtype=float), start_q)))
                            - 1.0) < 1e-9)

    # Planning ----------------------------------------------------------------------------

    def _base_poses(self, start: Pose) -> list[tuple[Pose, np.ndarray]]:
        """Base poses (facing the anchor) and the unit vector from the anchor to the base,
        one per bearing."""
        assert self.preview is not None
        if self.anchor == "middle":
            xy = self.preview.positions[:, :2]
            centre = np.append((xy.min(axis=0) + xy.max(axis=0)) / 2.0, 0.0)
        else:
            centre = start.position * np.array([1.0, 1.0, 0.0])
        bearings = self.settings.base_bearings or self.bearings
        poses = []
        for bearing in bearings:
            towards = np.array([np.cos(bearing), np.sin(bearing), 0.0])
            poses.append((Pose.from_euler(centre + self.settings.base_distance * towards,
                                          yaw=bearing + np.pi), towards))
        return poses

    def _candidates(self, grasps: Sequence[Grasp], start: Pose, base: Pose,
                    towards: np.ndarray) -> list[Grasp]:
        """At most ``max_grasps`` grasps for this base: the palm must not face the base
        (approach · (from base to tool) ≥ -0.1); kinds in the order given (a cup's side
        grasps before its rim grasps), nearest hand to the base first."""
        kinds = list(dict.fromkeys(grasp.kind for grasp in grasps))
        ranked = []
        for grasp in grasps:
            gripper = grasp.gripper_pose(start)
            approach = gripper.rotation()[:, 2]
            if float(approach @ -towards) < -0.1:
                continue
            distance = float(np.linalg.norm((gripper.position - base.position)[:2]))
            ranked.append((kinds.index(grasp.kind), distance, len(ranked), grasp))
        ranked.sort(key=lambda item: item[:3])
        return [grasp for *_, grasp in ranked[:self.settings.max_grasps]]

    def _grasp(self, tool: KitchenwareBody, start: Pose) -> None:
        if self.preview is None:
            raise ValueError("a robot trial needs the tool's path (preview) before the tool")
        client = self.world.client
        grasps = tool_grasps(tool.geometry, self.settings)
        if not grasps:
            raise RobotFailure("grasp", f"the {tool.geometry.kind} fits no grasp of the "
                               f"gripper")
        poses = [Pose(position, quaternion) for position, quaternion
                 in zip(self.preview.positions, self.preview.quaternions, strict=True)]
        rng = np.random.default_rng(self.seed)
        arm: PandaArm | None = None
        plan = None
        reasons = []
        for base, towards in self._base_poses(start):
            if arm is None:
                arm = PandaArm(client, base)
                self.state.arm = arm
            else:
                position, quaternion = base.as_tuples()
                p.resetBasePositionAndOrientation(arm.body_id, position, quaternion,
                                                  physicsClientId=client)
                arm.base_pose = base
            for grasp in self._candidates(grasps, start, base, towards):
                # The checker re-poses the held body by its base, which PyBullet puts at
                # the centre of mass: the body's pose in the gripper is the tool frame's
                # shifted by the kitchenware's com_offset (10 cm along a stirrer rod).
                checker = ArmCollisionChecker(arm, self.state.obstacles, AttachedBody(
                    tool.body, grasp.tool_in_gripper @ Pose(np.asarray(tool.com_offset))))
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
            if not reasons:
                raise RobotFailure("grasp", "no grasp with the palm away from the base")
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
        opening = plan.grasp.width + 0.002 if plan.grasp.kind != "fingertips" else 0.0
        arm.set_finger_opening(opening)
        arm.command_gripper(opening)
        self.state.command = first
        arm.command_configuration(first, position_gain=self.settings.position_gain)
        tool_pose = arm.end_effector_pose() @ plan.grasp.tool_in_gripper
        tool.set_pose(tool_pose.position, tool_pose.quaternion)
        for link in PANDA_HAND_LINKS:
            for piece in tool.links:
                p.setCollisionFilterPair(arm.body_id, tool.body, link, piece, 0,
                                         physicsClientId=client)
        if plan.grasp.kind == "fingertips":
            # The pad is the closed fingertips' contact shape (as in the free-floating
            # skill): the finger meshes around it do not touch the free bodies.
            for link in PANDA_HAND_LINKS[1:]:
                for body in self.state.free:
                    for piece in body.links:
                        p.setCollisionFilterPair(arm.body_id, body.body, link, piece, 0,
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
        """Drive the arm along the planned configurations by position control, one target
        per pose of ``path`` (the skill's timing, see :func:`skill_timed_configurations`)
        or trapezoidally timed (``skill_timing=False``); ``path`` must end where the preview
        ends. A tool the arm did not grasp moves free-floating."""
        if tool is not self.state.tool or self.state.plan is None:
            return super().follow(tool, path, on_step, step_offset)
        arm, plan = self._holding(tool)
        assert self.preview is not None
        if np.linalg.norm(path.positions[-1] - self.preview.positions[-1]) > 1e-6:
            raise ValueError("the robot follows the tool path it planned (the preview)")
        if self.settings.skill_timing:
            targets = skill_timed_configurations(plan.configurations, self.preview, path,
                                                 self.settings.cartesian)
        else:
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
        the arm holds it; ``position``/``quaternion`` are where the skill expects it). A
        tool the arm did not grasp is held free-floating."""
        if tool is not self.state.tool or self.state.plan is None:
            return super().hold(tool, position, quaternion, steps, on_step, step_offset)
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
        """Raise :class:`RobotFailure` on an arm collision (with the table, a fixed body, the
        tool other than by the hand, or a free body) or a slipped tool."""
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
        # Only the held tool may touch the manipulated object: the control names the tool's
        # contact, and the arm pushing the object instead is an unplanned contact. (The
        # fingers of a fingertip grasp are filtered out: the pad is their contact shape.)
        for body in self.state.free:
            for contact in p.getContactPoints(robot, body.body, physicsClientId=client):
                if contact[8] <= depth:
                    raise RobotFailure("collision", f"arm link {contact[3]} touched the "
                                       f"{body.geometry.kind} at step {step}")
        held = arm.end_effector_pose() @ plan.grasp.tool_in_gripper
        position, quaternion = tool.pose()
        actual = Pose(position, quaternion)
        drift = float(np.linalg.norm(actual.position - held.position))
        turn = rotation_distance(actual, held)
        if drift > self.settings.slip_position_m or turn > self.settings.slip_angle_rad:
            raise RobotFailure("slip", f"tool {drift:.3f} m / {turn:.2f} rad out of the grasp "
                               f"at step {step}")
