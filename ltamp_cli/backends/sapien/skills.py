"""Kitchen3D pour, scoop, push and stir trials in SAPIEN.

Same scenes, latents, tool paths, pre-checks and scores as the PyBullet skills: everything
but the physics comes from :mod:`ltamp_cli.backends.pybullet.skills` (``prepare_*`` parses
the context and control, builds the tool path and runs the pre-check; ``sample_*_latents``
draws the seed's bead count, sizes and materials; ``*_outcome`` turns the measurements
into the score and ``info``). Only the physics engine differs, so the two backends agree on
clearly good and clearly bad controls (borderline ones may differ).

The tool (cup, spoon, fingertip pad, stirrer) is a kinematic body driven by per-step targets;
the bowl is static; the pushed block and the stirred cup are dynamic.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ltamp_cli.backends.kitchenware_geometry import block_geometry, vessel_geometry
from ltamp_cli.backends.protocol import TrialResult
from ltamp_cli.backends.pybullet.particles import count_lost
from ltamp_cli.backends.pybullet.paths import PosePath, timed_poses
from ltamp_cli.backends.pybullet.skills.pour import (
    POUR_SPEED_M_S,
    PourSettings,
    pour_outcome,
    pour_too_few_beads,
    prepare_pour,
    sample_pour_latents,
)
from ltamp_cli.backends.pybullet.skills.push import (
    PushSettings,
    block_material,
    prepare_push,
    push_outcome,
)
from ltamp_cli.backends.pybullet.skills.scoop import (
    ScoopSettings,
    prepare_scoop,
    sample_scoop_latents,
    scoop_outcome,
)
from ltamp_cli.backends.pybullet.skills.stir import (
    StirSettings,
    TipTracker,
    prepare_stir,
    sample_stir_latents,
    stir_outcome,
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
    trial = prepare_pour(context, control, check)
    if trial.rejected is not None:
        return trial.rejected
    path = trial.path
    rng = np.random.default_rng(seed)
    latents = sample_pour_latents(rng, settings)
    world.reset()
    bowl = create_kitchenware(
        world, vessel_geometry(trial.scene.bowl, "bowl"), material=latents.bowl_material
    )
    cup = create_kitchenware(
        world,
        trial.tool,
        path.positions[0],
        path.quaternions[0],
        material=latents.cup_material,
        body_type="kinematic",
    )
    beads = spawn_beads_in(world, cup, latents.beads, rng)
    steps = hold(world, world.steps_for(settings.settle_s), on_step)
    started_in_cup = contained_mask(cup, beads.positions())
    too_few = pour_too_few_beads(len(beads), started_in_cup, latents.beads.radius)
    if too_few is not None:
        return too_few
    timed = timed_poses(
        path, speed=POUR_SPEED_M_S, angular_speed=settings.angular_speed,
        dt=world.config.time_step,
    )
    steps += follow_path(world, cup, timed, on_step, steps)
    steps += hold(world, world.steps_for(settings.hold_s), on_step, steps)
    end = beads.positions()
    return pour_outcome(latents.beads.radius, started_in_cup, contained_mask(cup, end),
                        contained_mask(bowl, end), count_lost(end), steps,
                        world.config.time_step)


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
    trial = prepare_scoop(context, control, check)
    if trial.rejected is not None:
        return trial.rejected
    path = trial.path
    rng = np.random.default_rng(seed)
    latents = sample_scoop_latents(rng, settings)
    world.reset()
    bowl = create_kitchenware(
        world, vessel_geometry(trial.scene.bowl, "bowl"), material=latents.bowl_material
    )
    spoon = create_kitchenware(
        world,
        trial.tool,
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
    return scoop_outcome(trial.scene, len(beads), in_bowl_start,
                         int(contained_mask(spoon, end).sum()), count_lost(end),
                         latents.beads.radius, steps, world.config.time_step)


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
    trial = prepare_push(context, control, check)
    if trial.rejected is not None:
        return trial.rejected
    scene, path = trial.scene, trial.path
    rng = np.random.default_rng(seed)
    world.reset()
    size = scene.size
    block = create_kitchenware(world, block_geometry((size, size, size)),
                               material=block_material(scene, rng), body_type="dynamic")
    pad = create_kitchenware(world, trial.tool, path.positions[0], path.quaternions[0],
                             body_type="kinematic")
    steps = hold(world, world.steps_for(settings.settle_s), on_step)
    timed = timed_poses(path, speed=float(trial.control[1]), angular_speed=1.0,
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
    trial = prepare_stir(context, control, check)
    if trial.rejected is not None:
        return trial.rejected
    path = trial.path
    rng = np.random.default_rng(seed)
    latents = sample_stir_latents(rng, settings)
    world.reset()
    cup_geometry = vessel_geometry(trial.scene, "cup")
    cup = create_kitchenware(world, cup_geometry, material=latents.cup_material,
                             body_type="dynamic")
    stirrer = create_kitchenware(world, trial.tool, path.positions[0], path.quaternions[0],
                                 body_type="kinematic")
    beads = spawn_beads_in(world, cup, latents.beads, rng)
    dt = world.config.time_step
    steps = hold(world, world.steps_for(settings.settle_s), on_step)
    start = beads.positions()
    in_start = contained_mask(cup, start)
    assert cup_geometry.cavity is not None
    tracker = TipTracker(cup_geometry.cavity, dt)
    track = tracker.callback(
        lambda: world_to_object(stirrer.pose()[0][None, :], *cup.pose())[0], on_step
    )
    timed = timed_poses(path, speed=float(trial.control[3]), angular_speed=1.0, dt=dt)
    steps += follow_path(world, stirrer, timed, track, steps)
    steps += hold(world, world.steps_for(settings.after_s), on_step, steps)
    end = beads.positions()
    return stir_outcome(start, end, in_start, contained_mask(cup, end), tracker, steps,
                        count_lost(end))
