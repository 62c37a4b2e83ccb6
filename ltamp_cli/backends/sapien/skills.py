"""Kitchen3D pour, scoop, push and stir trials in SAPIEN.

Same scenes, latents, tool paths, pre-checks and scores as the PyBullet skills
(:mod:`ltamp_cli.backends.pybullet.skills.pour` / ``.scoop``, whose pure parts are imported,
not copied): the seed draws the same bead count, sizes and materials, the beads start on the
same grid, and the tool follows the same timed path. Only the physics engine differs, so the
two backends agree on clearly good and clearly bad controls (borderline ones may differ).

The tool (cup, spoon, fingertip pad, stirrer) is a kinematic body driven by per-step targets;
the bowl is static; the pushed block and the stirred cup are dynamic.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ltamp_cli.backends.kitchenware_geometry import (
    block_geometry,
    spoon_geometry,
    stirrer_geometry,
    vessel_geometry,
)
from ltamp_cli.backends.protocol import TrialResult
from ltamp_cli.backends.pybullet.particles import count_lost
from ltamp_cli.backends.pybullet.paths import PosePath, timed_poses
from ltamp_cli.backends.pybullet.skills.common import (
    check_tool_path,
    sample_beads,
    sample_material,
)
from ltamp_cli.backends.pybullet.skills.pour import (
    MIN_BEADS_IN_CUP,
    POUR_SPEC,
    POUR_TAU,
    PourContext,
    PourSettings,
    pour_path,
    sample_pour_latents,
)
from ltamp_cli.backends.pybullet.skills.push import (
    PUSH_SPEC,
    PushContext,
    PushSettings,
    block_material,
    check_push,
    pad_geometry,
    push_outcome,
    push_path,
)
from ltamp_cli.backends.pybullet.skills.scoop import (
    SCOOP_SPEC,
    SCOOP_TAU,
    ScoopContext,
    ScoopSettings,
    sample_scoop_latents,
    scoop_path,
    spoon_capacity,
)
from ltamp_cli.backends.pybullet.skills.scoring import piecewise_linear_score
from ltamp_cli.backends.pybullet.skills.stir import (
    STIR_SPEC,
    STIRRER_LENGTH_M,
    StirSettings,
    TipTracker,
    cup_of,
    stir_outcome,
    stir_path,
)
from ltamp_cli.backends.sapien.bodies import (
    SapienBody,
    contained_mask,
    create_kitchenware,
    spawn_beads_in,
    world_to_object,
)
from ltamp_cli.backends.sapien.world import SapienWorld

StepCallback = Callable[[int], None]
#: Linear speed (m/s) of the cup's path segments, as in the PyBullet pour.
POUR_SPEED_M_S = 0.2


def follow_path(
    world: SapienWorld,
    tool: SapienBody,
    path: PosePath,
    on_step: StepCallback | None = None,
    step_offset: int = 0,
) -> int:
    """Drive kinematic ``tool`` through ``path`` (one pose per step, as in PyBullet: step
    ``i`` carries the tool from pose ``i`` to ``i + 1``). Returns the steps taken."""
    last = len(path) - 1
    for i in range(len(path)):
        target = min(i + 1, last)
        tool.move_to(path.positions[target], path.quaternions[target])
        world.step()
        if on_step is not None:
            on_step(step_offset + i)
    return len(path)


def hold(
    world: SapienWorld,
    steps: int,
    on_step: StepCallback | None = None,
    step_offset: int = 0,
) -> int:
    """Step ``steps`` times; kinematic tools stay where their last target put them."""
    for i in range(steps):
        world.step()
        if on_step is not None:
            on_step(step_offset + i)
    return steps


def run_pour(
    world: SapienWorld,
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    settings: PourSettings | None = None,
    on_step: StepCallback | None = None,
    check: bool = True,
) -> TrialResult:
    """Simulate one pour in ``world`` (reset first); deterministic given ``seed``.

    ``info`` has the same keys as the PyBullet pour (bead counts at start and end,
    ``fraction_in_bowl``, ``sim_steps``, ``sim_time_s``).
    """
    settings = settings or PourSettings()
    scene = PourContext.from_array(context)
    control = np.asarray(control, dtype=float).reshape(5)
    path = pour_path(scene, control)
    cup_geometry = vessel_geometry(scene.cup, "cup")
    if check:
        verdict = check_tool_path(cup_geometry, path, scene.bowl)
        if not verdict.valid:
            return TrialResult(POUR_SPEC.invalid_score, False, {"reason": verdict.reason})
    rng = np.random.default_rng(seed)
    latents = sample_pour_latents(rng, settings)
    world.reset()
    bowl = create_kitchenware(
        world, vessel_geometry(scene.bowl, "bowl"), material=latents.bowl_material
    )
    cup = create_kitchenware(
        world,
        cup_geometry,
        path.positions[0],
        path.quaternions[0],
        material=latents.cup_material,
        body_type="kinematic",
    )
    beads = spawn_beads_in(world, cup, latents.beads, rng)
    steps = hold(world, world.steps_for(settings.settle_s), on_step)
    started_in_cup = contained_mask(cup, beads.positions())
    in_cup = int(started_in_cup.sum())
    info: dict[str, object] = {
        "beads_total": len(beads),
        "beads_in_cup_start": in_cup,
        "bead_radius_m": latents.beads.radius,
    }
    if in_cup < MIN_BEADS_IN_CUP:
        info["reason"] = f"only {in_cup} beads in the cup at the start (need {MIN_BEADS_IN_CUP})"
        return TrialResult(POUR_SPEC.invalid_score, False, info)
    timed = timed_poses(
        path, speed=POUR_SPEED_M_S, angular_speed=settings.angular_speed,
        dt=world.config.time_step,
    )
    steps += follow_path(world, cup, timed, on_step, steps)
    steps += hold(world, world.steps_for(settings.hold_s), on_step, steps)
    end = beads.positions()
    in_cup_end = contained_mask(cup, end)
    in_bowl = contained_mask(bowl, end) & ~in_cup_end & started_in_cup
    fraction = float(in_bowl.sum()) / in_cup
    info.update(
        {
            "beads_in_bowl_end": int(in_bowl.sum()),
            "beads_in_cup_end": int(in_cup_end.sum()),
            "beads_lost": count_lost(end),
            "fraction_in_bowl": fraction,
            "sim_steps": steps,
            "sim_time_s": steps * world.config.time_step,
        }
    )
    return TrialResult(piecewise_linear_score(fraction, POUR_TAU), True, info)


def run_scoop(
    world: SapienWorld,
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    settings: ScoopSettings | None = None,
    on_step: StepCallback | None = None,
    check: bool = True,
) -> TrialResult:
    """Simulate one scoop in ``world`` (reset first); deterministic given ``seed``."""
    settings = settings or ScoopSettings()
    scene = ScoopContext.from_array(context)
    control = np.asarray(control, dtype=float).reshape(5)
    path = scoop_path(scene, control)
    spoon_geom = spoon_geometry(scene.spoon)
    if check:
        verdict = check_tool_path(spoon_geom, path, scene.bowl)
        if not verdict.valid:
            return TrialResult(SCOOP_SPEC.invalid_score, False, {"reason": verdict.reason})
    rng = np.random.default_rng(seed)
    latents = sample_scoop_latents(rng, settings)
    world.reset()
    bowl = create_kitchenware(
        world, vessel_geometry(scene.bowl, "bowl"), material=latents.bowl_material
    )
    spoon = create_kitchenware(
        world,
        spoon_geom,
        path.positions[0],
        path.quaternions[0],
        material=latents.spoon_material,
        body_type="kinematic",
    )
    beads = spawn_beads_in(world, bowl, latents.beads, rng)
    steps = hold(world, world.steps_for(settings.settle_s), on_step)
    in_bowl_start = int(contained_mask(bowl, beads.positions()).sum())
    timed = timed_poses(path, settings.speed, settings.angular_speed, world.config.time_step)
    steps += follow_path(world, spoon, timed, on_step, steps)
    steps += hold(world, world.steps_for(settings.hold_s), on_step, steps)
    end = beads.positions()
    in_spoon = int(contained_mask(spoon, end).sum())
    capacity = spoon_capacity(scene.spoon)
    fraction = min(1.0, in_spoon / capacity)
    info = {
        "beads_total": len(beads),
        "beads_in_bowl_start": in_bowl_start,
        "beads_in_spoon_end": in_spoon,
        "beads_lost": count_lost(end),
        "spoon_capacity": capacity,
        "fraction_of_capacity": fraction,
        "bead_radius_m": latents.beads.radius,
        "sim_steps": steps,
        "sim_time_s": steps * world.config.time_step,
    }
    return TrialResult(piecewise_linear_score(fraction, SCOOP_TAU), True, info)


def run_push(
    world: SapienWorld,
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    settings: PushSettings | None = None,
    on_step: StepCallback | None = None,
    check: bool = True,
) -> TrialResult:
    """Simulate one push in ``world`` (reset first); deterministic given ``seed``. Same
    block, pad path, draws and score as the PyBullet push."""
    settings = settings or PushSettings()
    scene = PushContext.from_array(context)
    control = np.asarray(control, dtype=float).reshape(4)
    if check:
        verdict = check_push(context, control)
        if not verdict.valid:
            return TrialResult(PUSH_SPEC.invalid_score, False, {"reason": verdict.reason})
    rng = np.random.default_rng(seed)
    world.reset()
    size = scene.size
    block = create_kitchenware(world, block_geometry((size, size, size)),
                               material=block_material(scene, rng), body_type="dynamic")
    path = push_path(scene, control)
    pad = create_kitchenware(world, pad_geometry(), path.positions[0], path.quaternions[0],
                             body_type="kinematic")
    steps = hold(world, world.steps_for(settings.settle_s), on_step)
    timed = timed_poses(path, speed=float(control[1]), angular_speed=1.0,
                        dt=world.config.time_step)
    steps += follow_path(world, pad, timed, on_step, steps)
    steps += hold(world, world.steps_for(settings.after_s), on_step, steps)
    position, quaternion = block.pose()
    return push_outcome(scene, position, quaternion, steps, world.config.time_step)


def run_stir(
    world: SapienWorld,
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    settings: StirSettings | None = None,
    on_step: StepCallback | None = None,
    check: bool = True,
) -> TrialResult:
    """Simulate one stir in ``world`` (reset first); deterministic given ``seed``. Same
    cup, beads, stirrer path, draws, tip rule and score as the PyBullet stir."""
    settings = settings or StirSettings()
    cup_dims = cup_of(context)
    control = np.asarray(control, dtype=float).reshape(4)
    path = stir_path(cup_dims, control)
    rod = stirrer_geometry(STIRRER_LENGTH_M)
    if check:
        verdict = check_tool_path(rod, path, cup_dims)
        if not verdict.valid:
            return TrialResult(STIR_SPEC.invalid_score, False, {"reason": verdict.reason})
    rng = np.random.default_rng(seed)
    beads_spec = sample_beads(rng, settings.bead_count_mean, 8.0, 40.0, 80.0)
    cup_material = sample_material(rng, (0.9, 0.5, 0.2, 1.0), mass=(0.15, 0.03, 0.08, 0.25))
    world.reset()
    cup_geometry = vessel_geometry(cup_dims, "cup")
    cup = create_kitchenware(world, cup_geometry, material=cup_material, body_type="dynamic")
    stirrer = create_kitchenware(world, rod, path.positions[0], path.quaternions[0],
                                 body_type="kinematic")
    beads = spawn_beads_in(world, cup, beads_spec, rng)
    dt = world.config.time_step
    steps = hold(world, world.steps_for(settings.settle_s), on_step)
    start = beads.positions()
    in_start = contained_mask(cup, start)
    assert cup_geometry.cavity is not None
    tracker = TipTracker(cup_geometry.cavity, dt)

    def track(step: int) -> None:
        tip, _ = stirrer.pose()
        tracker.add(world_to_object(tip[None, :], *cup.pose())[0])
        if on_step is not None:
            on_step(step)

    timed = timed_poses(path, speed=float(control[3]), angular_speed=1.0, dt=dt)
    steps += follow_path(world, stirrer, timed, track, steps)
    steps += hold(world, world.steps_for(settings.after_s), on_step, steps)
    end = beads.positions()
    return stir_outcome(start, end, in_start, contained_mask(cup, end), tracker, steps,
                        count_lost(end))
