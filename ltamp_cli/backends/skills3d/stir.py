"""Stir: a stirrer rod goes down into a cup of beads, circles about the cup's axis, comes out.

Frames: the cup's base centre is the world origin (table top, ``z = 0``). The stirrer's frame
has its tip at the origin and the rod along ``+z`` (:func:`stirrer_geometry`); it stays
upright. Path: above the cup's centre (tip :data:`ENTRY_HEIGHT_M` over the rim) → down to the
stirring height → out to the circle → ``revolutions`` turns (:data:`WAYPOINTS_PER_TURN`
waypoints each) → back to the centre → up.

Context (3, metres): cup top diameter, cup height, cup base diameter (the pour cup's ranges).

Control (4):

* ``radius`` ∈ [0, 0.05] m: circle radius of the tip about the cup's axis;
* ``tip_height`` ∈ [0.005, 0.12] m: the tip's height above the cup's base while circling
  (above the rim it stirs nothing);
* ``revolutions`` ∈ [0.5, 3];
* ``speed`` ∈ [0.02, 0.3] m/s: tip speed.

A control whose rod would touch the cup (wall or floor) or the table is invalid and not
simulated (the pour pre-check, with the cup as the vessel).

Measured: the beads in the cup after settling and at the end, the mean displacement of the
beads that stayed in, and whether the tip was *stirring*: inside the cup's containment prism
(below the rim) for at least :data:`STIR_MIN_TIME_S` of simulated time while travelling at
least :data:`STIR_MIN_TRAVEL_M` inside it (the rule of the executor's ``(Stirred c)``).
Score: ``min(d / STIR_DISPLACEMENT_M − 1, (k − STIR_RETAIN) / (1 − STIR_RETAIN))`` clipped to
``[-1, 1]`` (``d`` mean displacement, ``k`` fraction of beads kept), −1 when not stirring:
``g > 0`` when the beads moved by more than a bead diameter on average and ≥ 95 % stayed in.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ltamp_cli.backends.kitchenware_geometry import (
    ContainmentPrism,
    VesselDims,
    stirrer_geometry,
    vessel_geometry,
)
from ltamp_cli.backends.protocol import ParamSpace, SkillSpec, TrialResult
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial
from ltamp_cli.backends.pybullet.particles import BeadSpec
from ltamp_cli.backends.pybullet.paths import PosePath, timed_poses
from ltamp_cli.backends.skills3d.common import (
    PathCheck,
    SkillTrial,
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
    world_to_object,
)
from ltamp_cli.backends.skills3d.pour import CUP_BASE_RATIO, NOMINAL_CUP, SCALE_RANGE

STIRRER_LENGTH_M = 0.2
ENTRY_HEIGHT_M = 0.03
WAYPOINTS_PER_TURN = 16
#: ``(Stirred c)``: the tip inside the cup this long (s) while travelling this far (m).
STIR_MIN_TIME_S = 0.5
STIR_MIN_TRAVEL_M = 0.05
#: Score: mean bead displacement (m) counted as mixing, and the fraction that must stay in.
STIR_DISPLACEMENT_M = 0.012
STIR_RETAIN = 0.95
#: Turn rate (rad/s) bounding the stirrer's rotation along a trial's path (the rod stays
#: upright, so only a path that turns it is slowed by it); the tip's speed is a control.
STIR_ANGULAR_SPEED = 1.0
IDENTITY_QUAT = np.array([0.0, 0.0, 0.0, 1.0])
#: The stirrer's material (a tool: engines with true kinematic tools ignore the mass).
STIRRER_MATERIAL = BodyMaterial(mass=0.05, rgba=(0.6, 0.6, 0.65, 1.0))

STIR_CONTEXT = ParamSpace(
    names=("cup_diameter", "cup_height", "cup_base_diameter"),
    lows=(0.064, 0.08, 0.0448),
    highs=(0.10, 0.125, 0.10),
    units=("m", "m", "m"),
)
STIR_CONTROL = ParamSpace(
    names=("radius", "tip_height", "revolutions", "speed"),
    lows=(0.0, 0.005, 0.5, 0.02),
    highs=(0.05, 0.12, 3.0, 0.3),
    units=("m", "m", "turns", "m/s"),
)
STIR_SPEC = SkillSpec(
    name="stir",
    context=STIR_CONTEXT,
    control=STIR_CONTROL,
    description="stir the beads in a cup with a rod moving in circles (Kitchen3D)",
)


@dataclass(frozen=True)
class StirSettings:
    """Timing (s) and the mean bead count of a stir trial."""

    settle_s: float = 0.3
    after_s: float = 0.3
    bead_count_mean: float = 60.0


def cup_of(context: np.ndarray) -> VesselDims:
    """The cup of a stir context ``(3,)``."""
    c = np.asarray(context, dtype=float).reshape(-1)
    if c.shape != (3,):
        raise ValueError(f"a stir context has 3 values, got {c.shape[0]}")
    return VesselDims(base_diameter=float(c[2]), top_diameter=float(c[0]), height=float(c[1]))


def sample_stir_context(rng: np.random.Generator) -> np.ndarray:
    """A randomly scaled cup (the pour cup's distribution), shape ``(3,)``."""
    cup = NOMINAL_CUP.scaled(rng.uniform(*SCALE_RANGE), rng.uniform(*SCALE_RANGE))
    base = cup.top_diameter * rng.uniform(*CUP_BASE_RATIO)
    return np.array([cup.top_diameter, cup.height, base])


def stir_path(cup: VesselDims, control: np.ndarray) -> PosePath:
    """Stirrer (tip) poses in the cup's frame, upright; see the module docstring."""
    radius, tip_height, revolutions, _ = np.asarray(control, dtype=float).reshape(4)
    top = cup.height + ENTRY_HEIGHT_M
    n = max(2, math.ceil(revolutions * WAYPOINTS_PER_TURN))
    angles = np.linspace(0.0, 2.0 * math.pi * revolutions, n + 1)
    circle = np.stack([radius * np.cos(angles), radius * np.sin(angles),
                       np.full_like(angles, tip_height)], axis=1)
    positions = np.concatenate([
        [[0.0, 0.0, top], [0.0, 0.0, tip_height]],
        circle,
        [[0.0, 0.0, tip_height], [0.0, 0.0, top]],
    ])
    return PosePath(positions, np.tile(IDENTITY_QUAT, (len(positions), 1)))


def check_stir(context: np.ndarray, control: np.ndarray) -> PathCheck:
    """The geometric pre-check: the rod stays clear of the cup and the table."""
    cup = cup_of(context)
    return check_tool_path(stirrer_geometry(STIRRER_LENGTH_M), stir_path(cup, control), cup)


def prepare_stir(context: np.ndarray, control: np.ndarray, check: bool
                 ) -> SkillTrial[VesselDims]:
    """Context ``(3,)`` parsed into the cup, control ``(4,)``, the rod's path and geometry,
    and (with ``check``) the pre-check's rejection: the engine-independent start of a stir."""
    cup = cup_of(context)
    control = np.asarray(control, dtype=float).reshape(4)
    path = stir_path(cup, control)
    rod = stirrer_geometry(STIRRER_LENGTH_M)
    rejected = rejection(STIR_SPEC, check_tool_path(rod, path, cup)) if check else None
    return SkillTrial(cup, control, path, rod, rejected)


@dataclass(frozen=True)
class StirLatents:
    """Per-trial physical randomisation (drawn from the trial seed)."""

    beads: BeadSpec
    cup_material: BodyMaterial


def sample_stir_latents(rng: np.random.Generator, settings: StirSettings) -> StirLatents:
    beads = sample_beads(rng, settings.bead_count_mean, 8.0, 40.0, 80.0)
    cup = sample_material(rng, (0.9, 0.5, 0.2, 1.0), mass=(0.15, 0.03, 0.08, 0.25))
    return StirLatents(beads, cup)


def stir_is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """Pre-check of a batch ``controls (n, 4)``: bool ``(n,)``."""
    batch = np.asarray(controls, dtype=float).reshape(-1, 4)
    return np.array([check_stir(context, c).valid for c in batch], dtype=bool)


class TipTracker:
    """Accumulates how long (s) and how far (m) a stirrer tip moved inside a container's
    containment prism. Feed it the tip in the container's frame once per step."""

    def __init__(self, cavity: ContainmentPrism, dt: float) -> None:
        self.cavity = cavity
        self.dt = dt
        self.time_inside_s = 0.0
        self.travel_inside_m = 0.0
        self._last: np.ndarray | None = None

    def add(self, tip_in_container: np.ndarray) -> None:
        tip = np.asarray(tip_in_container, dtype=float).reshape(3)
        if bool(self.cavity.contains(tip)[0]):
            self.time_inside_s += self.dt
            if self._last is not None:
                self.travel_inside_m += float(np.linalg.norm(tip - self._last))
            self._last = tip
        else:
            self._last = None

    def callback(self, tip_in_container: Callable[[], np.ndarray],
                 on_step: StepCallback | None) -> StepCallback:
        """A step callback that adds ``tip_in_container()`` (the tip ``(3,)`` in the
        container's frame, read from the simulation) and then calls ``on_step``."""

        def track(step: int) -> None:
            self.add(tip_in_container())
            if on_step is not None:
                on_step(step)

        return track

    @property
    def stirred(self) -> bool:
        return (self.time_inside_s >= STIR_MIN_TIME_S - 1e-9
                and self.travel_inside_m >= STIR_MIN_TRAVEL_M)

    def to_json(self) -> dict[str, float | bool]:
        return {"tip_time_inside_s": self.time_inside_s,
                "tip_travel_inside_m": self.travel_inside_m, "stirred": self.stirred}


def stir_score(stirred: bool, displacement_m: float, kept: float) -> float:
    """See the module docstring; positive exactly when stirred, mixed and kept."""
    if not stirred:
        return -1.0
    mixing = displacement_m / STIR_DISPLACEMENT_M - 1.0
    keeping = (kept - STIR_RETAIN) / (1.0 - STIR_RETAIN)
    return float(np.clip(min(mixing, keeping), -1.0, 1.0))


def stir_outcome(start: np.ndarray, end: np.ndarray, in_start: np.ndarray, in_end: np.ndarray,
                 tracker: TipTracker, steps: int, lost: int) -> TrialResult:
    """Score and ``info`` from bead positions ``(n, 3)`` and containment masks ``(n,)`` at
    the start and the end (shared with the SAPIEN stir)."""
    kept_mask = in_start & in_end
    kept = float(kept_mask.sum()) / max(int(in_start.sum()), 1)
    moved = np.linalg.norm(end[kept_mask] - start[kept_mask], axis=1)
    displacement = float(moved.mean()) if moved.size else 0.0
    info: dict[str, object] = {
        "beads_total": len(start),
        "beads_in_cup_start": int(in_start.sum()),
        "beads_in_cup_end": int(in_end.sum()),
        "fraction_kept": kept,
        "mean_displacement_m": displacement,
        "beads_lost": lost,
        "sim_steps": steps,
        "sim_time_s": steps * tracker.dt,
        **tracker.to_json(),
    }
    return TrialResult(stir_score(tracker.stirred, displacement, kept), True, info)


def run_stir(
    physics: TrialPhysics,
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    settings: StirSettings | None = None,
    on_step: StepCallback | None = None,
    check: bool = True,
) -> TrialResult:
    """Simulate one stir with ``physics`` (reset first); deterministic given ``seed``. The
    cup is free (a rough stir can shove or tip it); the stirrer is a tool."""
    settings = settings or StirSettings()
    trial = prepare_stir(context, control, check)
    if trial.rejected is not None:
        return trial.rejected
    path = trial.path
    rng = np.random.default_rng(seed)
    latents = sample_stir_latents(rng, settings)
    physics.reset()
    cup_geometry = vessel_geometry(trial.scene, "cup")
    cup = physics.add_body(cup_geometry, latents.cup_material, "free")
    stirrer = physics.add_body(trial.tool, STIRRER_MATERIAL, "tool", path.positions[0],
                               path.quaternions[0])
    beads = physics.spawn_beads_in(cup, latents.beads, rng)
    dt = physics.time_step
    steps = physics.hold(stirrer, path.positions[0], path.quaternions[0],
                         physics.steps_for(settings.settle_s), on_step)
    start = beads.positions()
    in_start = contained_mask(cup, start)
    assert cup_geometry.cavity is not None
    tracker = TipTracker(cup_geometry.cavity, dt)
    timed = timed_poses(path, speed=float(trial.control[3]), angular_speed=STIR_ANGULAR_SPEED,
                        dt=dt)
    track = tracker.callback(
        lambda: world_to_object(stirrer.pose()[0][None, :], *cup.pose())[0], on_step
    )
    steps += physics.follow(stirrer, timed, track, steps)
    steps += physics.hold(stirrer, path.positions[-1], path.quaternions[-1],
                          physics.steps_for(settings.after_s), on_step, steps)
    end = beads.positions()
    return stir_outcome(start, end, in_start, contained_mask(cup, end), tracker, steps,
                        count_lost(end))


__all__ = [
    "STIR_ANGULAR_SPEED", "STIR_CONTEXT", "STIR_CONTROL", "STIR_MIN_TIME_S",
    "STIR_MIN_TRAVEL_M", "STIR_SPEC",
    "StirLatents", "StirSettings", "TipTracker", "check_stir", "cup_of", "prepare_stir",
    "run_stir", "sample_stir_context", "sample_stir_latents",
    "stir_is_valid", "stir_outcome", "stir_path", "stir_score",
]
