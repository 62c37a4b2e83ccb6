"""Pour: tilt a cup of beads about a pivot so the beads land in a bowl.

Frames: the bowl's base centre is the world origin (on the table, ``z = 0``); the cup comes
from the ``+x`` side and pours towards ``-x``.

Context (6, metres): bowl top diameter, bowl height, bowl base diameter, cup top diameter,
cup height, cup base diameter.

Control (5):

* ``pitch`` (rad, in ``[-π, -π/2]``): final rotation of the cup about the world ``y`` axis;
* ``cup_pivot_x``, ``cup_pivot_z`` (fractions of cup diameter / height, ``[-0.75, 0.75]``):
  the pivot relative to the centre of the upright cup's bounding box;
* ``bowl_pivot_x`` (fraction of bowl diameter, ``[-0.25, 0.75]``) and ``bowl_pivot_z``
  (metres above the bowl's rim, ``[0, 0.15]``): where the pivot is relative to the bowl.

The cup starts upright with its pivot at the bowl pivot and rotates about it in ``π/16``
waypoints up to ``pitch``. A control whose cup path touches the bowl or the table is invalid
and is not simulated. Beads as in the reference: up to 100, filling the cup to a random 75-100 %
of its height, with randomised size, mass, restitution and damping
(:func:`sample_pour_beads`). Score: ``g(x; τ = 0.9)`` with ``x`` = beads in the bowl at the
end / beads in the cup after settling; trials with fewer than 10 beads in the cup are
dropped (invalid), as the reference drops them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ltamp_cli.backends.kitchenware_geometry import KitchenwareGeometry, VesselDims, vessel_geometry
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
    sample_material,
    truncated_normal,
)
from ltamp_cli.backends.skills3d.physics import (
    StepCallback,
    TrialPhysics,
    contained_mask,
    count_lost,
)
from ltamp_cli.backends.skills3d.scoring import piecewise_linear_score

POUR_TAU = 0.9
MIN_BEADS_IN_CUP = 10
PITCH_STEP_RAD = math.pi / 16
#: Linear speed (m/s) of the cup along its path segments.
POUR_SPEED_M_S = 0.2

#: Nominal measured-style dimensions (metres), scaled per context.
NOMINAL_BOWL = VesselDims(base_diameter=0.12, top_diameter=0.20, height=0.08)
NOMINAL_CUP = VesselDims(base_diameter=0.068, top_diameter=0.08, height=0.10)
SCALE_RANGE = (0.8, 1.25)
BOWL_BASE_RATIO = (0.5, 0.75)
CUP_BASE_RATIO = (0.7, 1.0)

POUR_CONTEXT = ParamSpace(
    names=(
        "bowl_diameter",
        "bowl_height",
        "bowl_base_diameter",
        "cup_diameter",
        "cup_height",
        "cup_base_diameter",
    ),
    lows=(0.16, 0.064, 0.08, 0.064, 0.08, 0.0448),
    highs=(0.25, 0.10, 0.1875, 0.10, 0.125, 0.10),
    units=("m",) * 6,
)
POUR_CONTROL = ParamSpace(
    names=("pitch", "cup_pivot_x", "cup_pivot_z", "bowl_pivot_x", "bowl_pivot_z"),
    lows=(-math.pi, -0.75, -0.75, -0.25, 0.0),
    highs=(-math.pi / 2, 0.75, 0.75, 0.75, 0.15),
    units=("rad", "× cup diameter", "× cup height", "× bowl diameter", "m"),
)
POUR_SPEC = SkillSpec(
    name="pour",
    context=POUR_CONTEXT,
    control=POUR_CONTROL,
    description="tilt a cup of beads about a pivot to pour them into a bowl (Kitchen3D)",
)


@dataclass(frozen=True)
class PourSettings:
    """Simulation timing: settle/hold in seconds, tilt speed in rad/s. Beads as in the
    reference: at most ``bead_count`` are created (a quick check can simulate fewer), filling
    the upright cup up to a fraction of its height drawn uniformly from ``fill_range``."""

    settle_s: float = 0.3
    hold_s: float = 0.8
    angular_speed: float = 2.0
    bead_count: int = 100
    fill_range: tuple[float, float] = (0.75, 1.0)

    def __post_init__(self) -> None:
        low, high = self.fill_range
        if not (0.0 < low <= high <= 1.0):
            raise ValueError(f"fill_range must satisfy 0 < low <= high <= 1, got {self.fill_range}")
        if self.bead_count < 1:
            raise ValueError("bead_count must be at least 1")


@dataclass(frozen=True)
class PourContext:
    """The bowl and the cup of one pour context."""

    bowl: VesselDims
    cup: VesselDims

    @staticmethod
    def from_array(context: np.ndarray) -> PourContext:
        c = np.asarray(context, dtype=float).reshape(-1)
        if c.shape != (6,):
            raise ValueError(f"a pour context has 6 values, got {c.shape[0]}")
        return PourContext(
            bowl=VesselDims(base_diameter=c[2], top_diameter=c[0], height=c[1]),
            cup=VesselDims(base_diameter=c[5], top_diameter=c[3], height=c[4]),
        )

    def to_array(self) -> np.ndarray:
        b, c = self.bowl, self.cup
        return np.array(
            [b.top_diameter, b.height, b.base_diameter, c.top_diameter, c.height, c.base_diameter]
        )


def sample_pour_context(rng: np.random.Generator) -> np.ndarray:
    """Randomly scaled bowl and cup (diameter and height independently), shape ``(6,)``."""
    bowl = NOMINAL_BOWL.scaled(rng.uniform(*SCALE_RANGE), rng.uniform(*SCALE_RANGE))
    bowl = VesselDims(
        bowl.top_diameter * rng.uniform(*BOWL_BASE_RATIO), bowl.top_diameter, bowl.height
    )
    cup = NOMINAL_CUP.scaled(rng.uniform(*SCALE_RANGE), rng.uniform(*SCALE_RANGE))
    cup = VesselDims(cup.top_diameter * rng.uniform(*CUP_BASE_RATIO), cup.top_diameter, cup.height)
    return PourContext(bowl, cup).to_array()


def pour_pivot(context: PourContext, control: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World pivot ``(3,)`` and the upright cup's base position ``(3,)`` for a control."""
    _, cup_x, cup_z, bowl_x, bowl_z = np.asarray(control, dtype=float)
    bowl, cup = context.bowl, context.cup
    pivot = np.array([bowl_x * bowl.top_diameter, 0.0, bowl.height + bowl_z])
    offset = np.array([cup_x * cup.max_radius * 2.0, 0.0, cup.height / 2.0 + cup_z * cup.height])
    return pivot, pivot - offset


def pour_path(context: PourContext, control: np.ndarray) -> PosePath:
    """Cup poses (base frame) from upright to ``pitch`` in ``π/16`` waypoints about the pivot."""
    pitch = float(control[0])
    pivot, base = pour_pivot(context, control)
    n = max(1, math.ceil(abs(pitch) / PITCH_STEP_RAD - 1e-9))
    angles = np.linspace(0.0, pitch, n + 1)
    positions, quaternions = [], []
    for angle in angles:
        c, s = math.cos(angle), math.sin(angle)
        rotation = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
        positions.append(pivot + rotation @ (base - pivot))
        quaternions.append(rotation_about_axis("y", angle))
    return PosePath(np.array(positions), np.array(quaternions))


def check_pour(context: np.ndarray, control: np.ndarray) -> PathCheck:
    """The geometric pre-check of one control, with the reason when it fails."""
    scene = PourContext.from_array(context)
    control = np.asarray(control, dtype=float).reshape(5)
    return check_tool_path(vessel_geometry(scene.cup, "cup"), pour_path(scene, control), scene.bowl)


def prepare_pour(context: np.ndarray, control: np.ndarray, check: bool) -> SkillTrial[PourContext]:
    """Context ``(6,)`` and control ``(5,)`` parsed, the cup's path and geometry, and (with
    ``check``) the pre-check's rejection: the engine-independent start of a pour trial."""
    scene = PourContext.from_array(context)
    control = np.asarray(control, dtype=float).reshape(5)
    path = pour_path(scene, control)
    cup: KitchenwareGeometry = vessel_geometry(scene.cup, "cup")
    rejected = rejection(POUR_SPEC, check_tool_path(cup, path, scene.bowl)) if check else None
    return SkillTrial(scene, control, path, cup, rejected)


def _pour_start_info(total: int, started_in_cup: np.ndarray, bead_radius: float
                     ) -> dict[str, object]:
    return {
        "beads_total": total,
        "beads_in_cup_start": int(started_in_cup.sum()),
        "bead_radius_m": bead_radius,
    }


def pour_too_few_beads(total: int, started_in_cup: np.ndarray, bead_radius: float
                       ) -> TrialResult | None:
    """The rejected result when fewer than :data:`MIN_BEADS_IN_CUP` of the ``total`` beads
    are in the cup after settling (``started_in_cup``: bool ``(total,)``), else ``None``."""
    in_cup = int(started_in_cup.sum())
    if in_cup >= MIN_BEADS_IN_CUP:
        return None
    info = _pour_start_info(total, started_in_cup, bead_radius)
    info["reason"] = f"only {in_cup} beads in the cup at the start (need {MIN_BEADS_IN_CUP})"
    return TrialResult(POUR_SPEC.invalid_score, False, info)


def pour_outcome(bead_radius: float, started_in_cup: np.ndarray, in_cup_end: np.ndarray,
                 in_bowl_end: np.ndarray, lost: int, steps: int, dt: float) -> TrialResult:
    """Score and ``info`` of a simulated pour (shared with the SAPIEN pour).

    Masks are bool ``(n_beads,)``: in the cup after settling, in the cup and in the bowl at
    the end; ``lost`` beads fell off the table; ``steps`` of ``dt`` s were simulated. The
    fraction poured counts beads that started in the cup and ended in the bowl (not the cup).
    """
    in_bowl = in_bowl_end & ~in_cup_end & started_in_cup
    fraction = float(in_bowl.sum()) / int(started_in_cup.sum())
    info = _pour_start_info(len(started_in_cup), started_in_cup, bead_radius)
    info.update(
        {
            "beads_in_bowl_end": int(in_bowl.sum()),
            "beads_in_cup_end": int(in_cup_end.sum()),
            "beads_lost": lost,
            "fraction_in_bowl": fraction,
            "sim_steps": steps,
            "sim_time_s": steps * dt,
        }
    )
    return TrialResult(piecewise_linear_score(fraction, POUR_TAU), True, info)


def pour_is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """Geometric pre-check for a batch ``controls (n, 5)``: bool ``(n,)``."""
    scene = PourContext.from_array(context)
    batch = np.asarray(controls, dtype=float).reshape(-1, 5)
    return batch_path_validity(vessel_geometry(scene.cup, "cup"),
                               (pour_path(scene, c) for c in batch), scene.bowl)


@dataclass(frozen=True)
class PourLatents:
    """Per-trial physical randomisation (drawn from the trial seed)."""

    beads: BeadSpec
    bowl_material: BodyMaterial
    cup_material: BodyMaterial


def sample_pour_beads(rng: np.random.Generator, settings: PourSettings, cup: VesselDims
                      ) -> BeadSpec:
    """The reference's pour beads (field facts): radius N(6, 1) mm (at least 4 mm), mass
    N(1, 0.2) g, restitution N(0.8, 0.1), friction N(0.5, 0.1), rolling and spinning
    friction 0.001, damping N(0.04, 0.01) 1/s; up to ``settings.bead_count`` filling the
    cup to a uniform fraction of its height in ``settings.fill_range``.
    Draw order: radius, mass, friction, restitution, damping, fill."""
    return BeadSpec(
        count=settings.bead_count,
        radius=truncated_normal(rng, 0.006, 0.001, 0.004, 0.009),
        mass=truncated_normal(rng, 0.001, 0.0002, 0.0004, 0.0016),
        lateral_friction=truncated_normal(rng, 0.5, 0.1, 0.2, 0.8),
        restitution=truncated_normal(rng, 0.8, 0.1, 0.5, 0.99),
        rolling_friction=0.001,
        spinning_friction=0.001,
        damping=truncated_normal(rng, 0.04, 0.01, 0.01, 0.07),
        fill_height=rng.uniform(*settings.fill_range) * cup.height,
    )


def sample_pour_latents(rng: np.random.Generator, settings: PourSettings, cup: VesselDims
                        ) -> PourLatents:
    """Beads (:func:`sample_pour_beads`), then the bowl's and the cup's materials."""
    beads = sample_pour_beads(rng, settings, cup)
    bowl = sample_material(rng, BOWL_RGBA)
    cup_material = sample_material(rng, (0.9, 0.5, 0.2, 1.0), mass=(0.15, 0.03, 0.08, 0.25))
    return PourLatents(beads, bowl, cup_material)


def run_pour(
    physics: TrialPhysics,
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    settings: PourSettings | None = None,
    on_step: StepCallback | None = None,
    check: bool = True,
) -> TrialResult:
    """Simulate one pour with ``physics`` (reset first); deterministic given ``seed``.

    The bowl is fixed; the cup is a tool: filled upright, settled, turned about the pivot,
    held. ``info``: bead counts at the start and the end, ``fraction_in_bowl``,
    ``sim_steps``, ``sim_time_s``.
    """
    settings = settings or PourSettings()
    trial = prepare_pour(context, control, check)
    if trial.rejected is not None:
        return trial.rejected
    path, scene = trial.path, trial.scene
    rng = np.random.default_rng(seed)
    latents = sample_pour_latents(rng, settings, scene.cup)
    physics.reset()
    bowl = physics.add_body(vessel_geometry(scene.bowl, "bowl"), latents.bowl_material, "fixed")
    cup = physics.add_body(trial.tool, latents.cup_material, "tool",
                           path.positions[0], path.quaternions[0])
    beads = physics.spawn_beads_in(cup, latents.beads, rng)
    steps = physics.hold(cup, path.positions[0], path.quaternions[0],
                         physics.steps_for(settings.settle_s), on_step)
    started_in_cup = contained_mask(cup, beads.positions())
    too_few = pour_too_few_beads(len(beads), started_in_cup, latents.beads.radius)
    if too_few is not None:
        return too_few
    dt = physics.time_step
    timed = timed_poses(path, speed=POUR_SPEED_M_S, angular_speed=settings.angular_speed, dt=dt)
    steps += physics.follow(cup, timed, on_step, steps)
    steps += physics.hold(cup, path.positions[-1], path.quaternions[-1],
                          physics.steps_for(settings.hold_s), on_step, steps)
    end = beads.positions()
    return pour_outcome(latents.beads.radius, started_in_cup, contained_mask(cup, end),
                        contained_mask(bowl, end), count_lost(end), steps, dt)
