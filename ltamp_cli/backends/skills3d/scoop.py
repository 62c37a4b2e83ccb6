"""Scoop: drag a spoon through the beads in a bowl and lift a spoonful out.

Frames: the bowl's base centre is the world origin; the scoop runs along the world ``y``
axis. The spoon's frame has its head's base centre at the origin, the head opening ``+z``
and the handle leaving towards ``+y``. While scooping the spoon is tilted by
``SCOOP_TILT_RAD`` about ``x`` (opening facing the direction of motion, ``-y``, handle
up); at the exit it is upright.

Context (4, metres): bowl top diameter, bowl height, bowl base diameter, spoon length.

Control (5):

* ``start_y`` ∈ [0, 0.5], ``end_y`` ∈ [-0.5, 0], ``exit_y`` ∈ [-0.5, 0.5]: fractions of the
  bowl diameter along ``y``;
* ``scoop_z`` ∈ [-0.02, 0.02] m: height of the head's lowest point while dragging, relative to
  ``SCOOP_CLEARANCE_M`` above the bowl's floor;
* ``exit_z`` ∈ [0, 0.05] m: height of the upright head's bottom above the bowl's rim.

Path: entry (above the start, 4 cm over the rim) → start → end → exit. Controls whose spoon
path touches the bowl or the table are invalid and not simulated. Score: ``g(x; τ = 0.7)``
with ``x`` = beads in the spoon's head at the end / the spoon's capacity, measured per trial
with the trial's beads (:func:`measure_spoon_capacity`).

The bed (:func:`scoop_bead_count`), as the reference fills a bowl for a scoop (caelan/LTAMP
``collect_scoop``: up to 250 beads, kept below 75 % of the bowl's height): about 250 beads
(200-300), but never a bed shallower than :data:`MIN_BED_DEPTH_M` and never above 75 % of
the bowl's height. The reference kept the bed deep enough by dropping the bowls where 250
beads lie too shallow ("too difficult to scoop from large items when only using 250
particles": its three widest bowls, beds of 16-21 mm at the estimate of :func:`bed_depth_m`,
against 26-47 mm in the twelve it kept); this context box keeps such bowls and adds beads
instead, so every bowl gets at least the bed of the reference's shallowest kept bowl.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ltamp_cli.backends.kitchenware_geometry import (
    KitchenwareGeometry,
    SpoonDims,
    VesselDims,
    spoon_geometry,
    vessel_geometry,
)
from ltamp_cli.backends.protocol import ParamSpace, SkillSpec, TrialResult
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial
from ltamp_cli.backends.pybullet.particles import BeadSpec
from ltamp_cli.backends.pybullet.paths import PosePath, rotation_about_axis, timed_poses
from ltamp_cli.backends.skills3d.common import (
    BOWL_RGBA,
    PathCheck,
    SkillTrial,
    batch_path_validity,
    check_tool_path,
    rejection,
    sample_beads,
    sample_material,
)
from ltamp_cli.backends.skills3d.physics import (
    StepCallback,
    TrialPhysics,
    contained_mask,
    count_lost,
)
from ltamp_cli.backends.skills3d.pour import (
    BOWL_BASE_RATIO,
    NOMINAL_BOWL,
    SCALE_RANGE,
)
from ltamp_cli.backends.skills3d.scoring import piecewise_linear_score

SCOOP_TAU = 0.7
SCOOP_TILT_RAD = math.radians(60.0)
SCOOP_CLEARANCE_M = 0.02
ENTRY_HEIGHT_M = 0.04
SPOON_LENGTH_RANGE = (0.16, 0.24)
#: Beads poured onto the spoon to measure its capacity (far more than any head holds).
CAPACITY_BEADS = 120
#: Height (m) of the spoon's frame above the table while its capacity is measured.
CAPACITY_LIFT_M = 0.05
#: The shallowest bed (m, :func:`bed_depth_m`) a scoop trial gets: the reference's shallowest
#: bowl it scooped from (``blue``, 10.5 / 22.3 / 9.5 cm, 250 beads of 5 mm: 25.9 mm with its
#: 1 cm walls). Its dropped bowls had 16-21 mm.
MIN_BED_DEPTH_M = 0.025
#: The reference keeps the beads below this fraction of the bowl's height.
MAX_FILL_FRACTION = 0.75
#: Volume fraction of a settled bed of beads, for the bed-depth estimate (random close
#: packing of equal spheres is ~0.64; measured on PyBullet after the 0.5 s settle: 0.45-0.66,
#: looser in shallow beds).
BED_PACKING = 0.6

SCOOP_CONTEXT = ParamSpace(
    names=("bowl_diameter", "bowl_height", "bowl_base_diameter", "spoon_length"),
    lows=(0.16, 0.064, 0.08, SPOON_LENGTH_RANGE[0]),
    highs=(0.25, 0.10, 0.1875, SPOON_LENGTH_RANGE[1]),
    units=("m", "m", "m", "m"),
)
SCOOP_CONTROL = ParamSpace(
    names=("start_y", "end_y", "exit_y", "scoop_z", "exit_z"),
    lows=(0.0, -0.5, -0.5, -0.02, 0.0),
    highs=(0.5, 0.0, 0.5, 0.02, 0.05),
    units=("× bowl diameter", "× bowl diameter", "× bowl diameter", "m", "m"),
)
SCOOP_SPEC = SkillSpec(
    name="scoop",
    context=SCOOP_CONTEXT,
    control=SCOOP_CONTROL,
    description="drag a spoon through beads in a bowl and lift a spoonful (Kitchen3D)",
)


@dataclass(frozen=True)
class ScoopSettings:
    """Timing: settle/hold in seconds, spoon speed m/s and turn rate rad/s; the bed: mean
    bead count drawn (200-300), shallowest bed (m) and highest fill (fraction of the bowl's
    height), see :func:`scoop_bead_count`."""

    settle_s: float = 0.5
    hold_s: float = 0.3
    speed: float = 0.15
    angular_speed: float = 1.5
    bead_count_mean: float = 250.0
    min_bed_depth_m: float = MIN_BED_DEPTH_M
    max_fill_fraction: float = MAX_FILL_FRACTION


@dataclass(frozen=True)
class ScoopContext:
    """The bowl and the spoon of one scoop context."""

    bowl: VesselDims
    spoon: SpoonDims

    @staticmethod
    def from_array(context: np.ndarray) -> ScoopContext:
        c = np.asarray(context, dtype=float).reshape(-1)
        if c.shape != (4,):
            raise ValueError(f"a scoop context has 4 values, got {c.shape[0]}")
        return ScoopContext(
            VesselDims(base_diameter=c[2], top_diameter=c[0], height=c[1]), SpoonDims(c[3])
        )

    def to_array(self) -> np.ndarray:
        b = self.bowl
        return np.array([b.top_diameter, b.height, b.base_diameter, self.spoon.length])


def sample_scoop_context(rng: np.random.Generator) -> np.ndarray:
    """A randomly scaled bowl and a spoon length, shape ``(4,)``."""
    bowl = NOMINAL_BOWL.scaled(rng.uniform(*SCALE_RANGE), rng.uniform(*SCALE_RANGE))
    base = bowl.top_diameter * rng.uniform(*BOWL_BASE_RATIO)
    bowl = VesselDims(base, bowl.top_diameter, bowl.height)
    return ScoopContext(bowl, SpoonDims(rng.uniform(*SPOON_LENGTH_RANGE))).to_array()


def _frustum_volume_m3(bowl: VesselDims, depth: float) -> float:
    """Volume (m³) of the bowl's cavity from its floor up to ``depth`` m (a frustum)."""
    r0 = bowl.base_diameter / 2.0 - bowl.thickness
    r1 = bowl.top_diameter / 2.0 - bowl.thickness
    slope = (r1 - r0) / (bowl.height - bowl.thickness)
    r = r0 + slope * depth
    return math.pi * depth / 3.0 * (r0 * r0 + r0 * r + r * r)


def bed_depth_m(bowl: VesselDims, count: float, radius: float) -> float:
    """Estimated depth (m above the floor) of ``count`` settled beads of ``radius`` m in
    ``bowl``: their volume at packing :data:`BED_PACKING` filling the cavity from the floor
    (capped at the cavity's depth)."""
    volume = count * 4.0 / 3.0 * math.pi * radius**3 / BED_PACKING
    lo, hi = 0.0, bowl.height - bowl.thickness
    for _ in range(60):  # bisection: the frustum's volume grows with the depth
        mid = (lo + hi) / 2.0
        lo, hi = (mid, hi) if _frustum_volume_m3(bowl, mid) < volume else (lo, mid)
    return lo


def beads_for_depth(bowl: VesselDims, depth: float, radius: float, at_most: bool = False
                    ) -> int:
    """The fewest beads of ``radius`` m whose bed (:func:`bed_depth_m`) is at least ``depth``
    m deep, or with ``at_most`` the most whose bed is at most ``depth`` m deep."""
    beads = _frustum_volume_m3(bowl, depth) * BED_PACKING / (4.0 / 3.0 * math.pi * radius**3)
    return math.floor(beads) if at_most else math.ceil(beads)


def scoop_bead_count(bowl: VesselDims, drawn: int, radius: float,
                     min_depth: float = MIN_BED_DEPTH_M,
                     max_fill: float = MAX_FILL_FRACTION) -> int:
    """Beads in a scoop trial's bowl: the ``drawn`` count (200-300), raised to a bed of
    ``min_depth`` m and capped at a bed reaching ``max_fill`` of the bowl's height (both by
    :func:`bed_depth_m`'s estimate), beads of ``radius`` m."""
    count = max(drawn, beads_for_depth(bowl, min_depth, radius))
    top = max_fill * bowl.height - bowl.thickness
    return min(count, beads_for_depth(bowl, top, radius, at_most=True))


def measure_spoon_capacity(physics: TrialPhysics, spoon: KitchenwareGeometry, beads: BeadSpec,
                           material: BodyMaterial, rng: np.random.Generator,
                           settle_s: float) -> int:
    """Beads of ``beads``' kind a level spoonful holds, measured (``physics`` is reset
    first): the upright spoon, clear of the table, is overfilled (a column of up to
    :data:`CAPACITY_BEADS` beads up to 4 × the head's height) and held still for
    ``settle_s`` s; the beads then inside the head's containment prism, the prism that
    counts a scooped spoonful, are its capacity (at least 1)."""
    physics.reset()
    tool = physics.add_body(spoon, material, "tool", (0.0, 0.0, CAPACITY_LIFT_M))
    pile = replace(beads, count=CAPACITY_BEADS, fill_height=None)
    filled = physics.spawn_beads_in(tool, pile, rng)
    position, quaternion = tool.pose()
    physics.hold(tool, position, quaternion, physics.steps_for(settle_s))
    return max(1, int(contained_mask(tool, filled.positions()).sum()))


def scoop_path(context: ScoopContext, control: np.ndarray) -> PosePath:
    """Spoon poses (object frame origin) at entry, start, end and exit, shape ``(4, ·)``."""
    start_y, end_y, exit_y, scoop_z, exit_z = np.asarray(control, dtype=float)
    bowl = context.bowl
    tilted = rotation_about_axis("x", SCOOP_TILT_RAD)
    upright = rotation_about_axis("x", 0.0)
    head = spoon_geometry(context.spoon)
    head_points = np.concatenate(head.pieces[:-1])  # all but the handle
    c, s = math.cos(SCOOP_TILT_RAD), math.sin(SCOOP_TILT_RAD)
    lowest_tilted = float((head_points[:, 1] * s + head_points[:, 2] * c).min())
    drag_z = bowl.thickness + SCOOP_CLEARANCE_M + scoop_z - lowest_tilted
    entry_z = bowl.height + ENTRY_HEIGHT_M - lowest_tilted
    d = bowl.top_diameter
    positions = np.array(
        [
            [0.0, start_y * d, entry_z],
            [0.0, start_y * d, drag_z],
            [0.0, end_y * d, drag_z],
            [0.0, exit_y * d, bowl.height + exit_z],
        ]
    )
    return PosePath(positions, np.stack([tilted, tilted, tilted, upright]))


def check_scoop(context: np.ndarray, control: np.ndarray) -> PathCheck:
    """The geometric pre-check of one control, with the reason when it fails."""
    scene = ScoopContext.from_array(context)
    control = np.asarray(control, dtype=float).reshape(5)
    return check_tool_path(spoon_geometry(scene.spoon), scoop_path(scene, control), scene.bowl)


def prepare_scoop(context: np.ndarray, control: np.ndarray, check: bool
                  ) -> SkillTrial[ScoopContext]:
    """Context ``(4,)`` and control ``(5,)`` parsed, the spoon's path and geometry, and (with
    ``check``) the pre-check's rejection: the engine-independent start of a scoop trial."""
    scene = ScoopContext.from_array(context)
    control = np.asarray(control, dtype=float).reshape(5)
    path = scoop_path(scene, control)
    spoon = spoon_geometry(scene.spoon)
    rejected = rejection(SCOOP_SPEC, check_tool_path(spoon, path, scene.bowl)) if check else None
    return SkillTrial(scene, control, path, spoon, rejected)


def scoop_outcome(capacity: int, total: int, in_bowl_start: int, in_spoon: int,
                  lost: int, bead_radius: float, steps: int, dt: float) -> TrialResult:
    """Score and ``info`` of a simulated scoop: the spoon's measured ``capacity`` (beads),
    ``total`` beads, ``in_bowl_start`` of them in the bowl after settling, ``in_spoon`` in
    the spoon's head at the end, ``lost`` off the table; ``steps`` of ``dt`` s simulated.

    ``info["fraction_of_capacity"]`` is ``in_spoon / capacity`` as measured (it can exceed 1
    when the scooped pile packs more densely than the measured spoonful); only the score
    clips it to ``[0, 1]``."""
    fraction = in_spoon / capacity
    info = {
        "beads_total": total,
        "beads_in_bowl_start": in_bowl_start,
        "beads_in_spoon_end": in_spoon,
        "beads_lost": lost,
        "spoon_capacity": capacity,
        "fraction_of_capacity": fraction,
        "bead_radius_m": bead_radius,
        "sim_steps": steps,
        "sim_time_s": steps * dt,
    }
    return TrialResult(piecewise_linear_score(fraction, SCOOP_TAU), True, info)


def scoop_is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """Geometric pre-check for a batch ``controls (n, 5)``: bool ``(n,)``."""
    scene = ScoopContext.from_array(context)
    batch = np.asarray(controls, dtype=float).reshape(-1, 5)
    return batch_path_validity(spoon_geometry(scene.spoon),
                               (scoop_path(scene, c) for c in batch), scene.bowl)


@dataclass(frozen=True)
class ScoopLatents:
    """Per-trial physical randomisation (drawn from the trial seed)."""

    beads: BeadSpec
    bowl_material: BodyMaterial
    spoon_material: BodyMaterial


def sample_scoop_latents(rng: np.random.Generator, settings: ScoopSettings,
                        bowl: VesselDims) -> ScoopLatents:
    """Beads (count by :func:`scoop_bead_count` for ``bowl``), then the bowl's and the
    spoon's materials; the draws from ``rng`` do not depend on ``bowl``."""
    beads = sample_beads(rng, settings.bead_count_mean, 20.0, 200.0, 300.0)
    beads = replace(beads, count=scoop_bead_count(
        bowl, beads.count, beads.radius, settings.min_bed_depth_m, settings.max_fill_fraction))
    bowl = sample_material(rng, BOWL_RGBA)
    spoon = sample_material(rng, (0.6, 0.6, 0.65, 1.0), mass=(0.05, 0.01, 0.02, 0.08))
    return ScoopLatents(beads, bowl, spoon)


def run_scoop(
    physics: TrialPhysics,
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    settings: ScoopSettings | None = None,
    on_step: StepCallback | None = None,
    check: bool = True,
) -> TrialResult:
    """Simulate one scoop with ``physics`` (reset first); deterministic given ``seed``.

    First the spoon's capacity for this trial's beads is measured
    (:func:`measure_spoon_capacity`), then the scene is reset: the bowl is fixed and
    filled, the spoon is a tool."""
    settings = settings or ScoopSettings()
    trial = prepare_scoop(context, control, check)
    if trial.rejected is not None:
        return trial.rejected
    path = trial.path
    rng = np.random.default_rng(seed)
    latents = sample_scoop_latents(rng, settings, trial.scene.bowl)
    capacity = measure_spoon_capacity(physics, trial.tool, latents.beads,
                                      latents.spoon_material, rng, settings.settle_s)
    physics.reset()
    bowl = physics.add_body(vessel_geometry(trial.scene.bowl, "bowl"), latents.bowl_material,
                            "fixed")
    spoon = physics.add_body(trial.tool, latents.spoon_material, "tool",
                             path.positions[0], path.quaternions[0])
    beads = physics.spawn_beads_in(bowl, latents.beads, rng)
    steps = physics.hold(spoon, path.positions[0], path.quaternions[0],
                         physics.steps_for(settings.settle_s), on_step)
    in_bowl_start = int(contained_mask(bowl, beads.positions()).sum())
    dt = physics.time_step
    timed = timed_poses(path, settings.speed, settings.angular_speed, dt)
    steps += physics.follow(spoon, timed, on_step, steps)
    steps += physics.hold(spoon, path.positions[-1], path.quaternions[-1],
                          physics.steps_for(settings.hold_s), on_step, steps)
    end = beads.positions()
    return scoop_outcome(capacity, len(beads), in_bowl_start,
                         int(contained_mask(spoon, end).sum()), count_lost(end),
                         latents.beads.radius, steps, dt)
