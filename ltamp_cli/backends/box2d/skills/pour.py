"""Pour: tip a held cup of particles over a target cup standing on the table.

Context (world units): ``cup_width, cup_height`` of the held (pouring) cup and
``target_width, target_height`` of the target cup; widths in [3, 8], heights in [3, 5].
Control: ``grasp_ratio`` in [0, 1] (grasp height on the held cup's handle bar, as a fraction
of its height), ``rel_x`` in [−10, 10] and ``rel_y`` in [1, 10] (grasp point relative to the
centre of the target cup's rim) and ``dangle`` in [π/2, π] (final tilt, clockwise, i.e. the
mouth turns towards +x, so the handle is on the left and a pour starts left of the target). The
gripper rotates about the grasp point at ``rotate_speed`` until the tilt is reached (or the
held cup would hit the table), then holds until no particle is in flight, or ``max_time``.

Score (seed paper): g = exp(2(10x − 9.5)) − 1 with x the fraction of the particles inside
the target cup, so g > 0 iff x > 0.95. A start where the gripper or held cup overlaps the
target cup or the table is invalid and scores −1 without simulating.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ltamp_cli.backends.box2d.geometry import aabbs, any_overlap
from ltamp_cli.backends.box2d.gripper import Gripper, GripperSpec
from ltamp_cli.backends.box2d.kitchenware import CupSpec, add_cup
from ltamp_cli.backends.box2d.particles import ParticleSpec, add_particles, hex_grid, inside_box
from ltamp_cli.backends.box2d.skills.common import freeze, lowest_y, new_kitchen
from ltamp_cli.backends.box2d.world import KitchenLayout, Observer
from ltamp_cli.backends.protocol import ParamSpace, SkillSpec, TrialResult

SPEC = SkillSpec(
    name="pour",
    context=ParamSpace(
        ("cup_width", "cup_height", "target_width", "target_height"),
        (3.0, 3.0, 3.0, 3.0),
        (8.0, 5.0, 8.0, 5.0),
        ("units", "units", "units", "units"),
    ),
    control=ParamSpace(
        ("grasp_ratio", "rel_x", "rel_y", "dangle"),
        (0.0, -10.0, 1.0, math.pi / 2),
        (1.0, 10.0, 10.0, math.pi),
        ("", "units", "units", "rad"),
    ),
    description="tip a held cup of particles into a target cup; g = exp(2(10x-9.5)) - 1",
)


@dataclass(frozen=True)
class PourConfig:
    """Simulation settings of a pour trial (see the benchmark for the particle count)."""

    n_particles: int = 200
    particle: ParticleSpec = field(default_factory=ParticleSpec)
    wall: float = 0.2
    rotate_speed: float = 1.0
    settle_time: float = 0.2
    max_time: float = 10.0
    rest_speed: float = 0.05
    check_every: int = 10
    gripper: GripperSpec = field(default_factory=GripperSpec)
    layout: KitchenLayout = field(default_factory=KitchenLayout)


def score(fraction: float) -> float:
    return math.exp(2.0 * (10.0 * fraction - 9.5)) - 1.0


def _cups(context: np.ndarray, config: PourConfig) -> tuple[CupSpec, CupSpec]:
    cw1, ch1, cw2, ch2 = (float(v) for v in context)
    return CupSpec(cw1, ch1, config.wall), CupSpec(cw2, ch2, config.wall)


def valid_mask(context: np.ndarray, controls: np.ndarray, config: PourConfig) -> np.ndarray:
    """Start-collision test for a batch of controls ``(n, 4)``; returns ``(n,)`` bools."""
    held, target = _cups(context, config)
    top = config.layout.table_top
    ratio, rel_x, rel_y = controls[:, 0], controls[:, 1], controls[:, 2]
    gx, gy = rel_x, top + target.height + rel_y
    heights = np.array([held.grasp_height(float(r)) for r in ratio])
    moving = np.concatenate(
        [
            aabbs(held.boxes(), gx - held.handle_x, gy - heights),
            aabbs(config.gripper.boxes(held.handle_width), gx, gy),
        ],
        axis=1,
    )
    n = len(controls)
    lay = config.layout
    table = np.tile([[lay.table_x0, top - lay.table_thickness, lay.table_x1, top]], (n, 1, 1))
    fixed = np.concatenate([aabbs(target.boxes(), np.zeros(n), np.full(n, top)), table], axis=1)
    return ~any_overlap(moving, fixed, margin=0.01)


def run(
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    config: PourConfig,
    observer: Observer | None = None,
) -> TrialResult:
    """Simulate one pour; deterministic given ``seed`` (it only jitters particle starts)."""
    if not valid_mask(context, control[None, :], config)[0]:
        return TrialResult(SPEC.invalid_score, False, {"reason": "colliding start"})
    held_spec, target_spec = _cups(context, config)
    ratio, rel_x, rel_y, dangle = (float(v) for v in control)
    top = config.layout.table_top
    kitchen = new_kitchen(observer, layout=config.layout)
    target = add_cup(kitchen, target_spec, (0.0, top, 0.0), name="target")
    gx, gy = rel_x, top + target_spec.height + rel_y
    gh = held_spec.grasp_height(ratio)
    cx = gx - held_spec.handle_x
    held = add_cup(kitchen, held_spec, (cx, gy - gh, 0.0), name="held", kind="dynamic")
    gripper = Gripper(kitchen, (gx, gy, 0.0), held_spec.handle_width, config.gripper)
    if not gripper.grasp(held):  # pragma: no cover - geometry guarantees finger contact
        raise RuntimeError("pour: gripper failed to grasp the held cup")

    rng = np.random.default_rng(seed)
    r = config.particle.radius
    inner = held_spec.inner_width / 2
    points = hex_grid(cx - inner, cx + inner, gy - gh + held_spec.wall, config.n_particles, r, rng)
    if points[:, 1].max() + r > gy - gh + held_spec.height:
        raise ValueError("pour: the particles do not fit in the held cup")
    particles = add_particles(kitchen, points, config.particle)
    gripper.hold(config.settle_time)

    # Tilt step by step, stopping early if the held cup would go through the table.
    blocked = False
    step_angle = config.rotate_speed * kitchen.config.dt
    angle = 0.0
    cup_boxes = held_spec.boxes()
    ox, oy = -held_spec.handle_x, -gh
    while angle > -dangle + 1e-12:
        nxt = max(angle - step_angle, -dangle)
        c, s = math.cos(nxt), math.sin(nxt)
        cup_pose = (gx + c * ox - s * oy, gy + s * ox + c * oy, nxt)
        if lowest_y(cup_boxes, cup_pose) < top:
            blocked = True
            break
        angle = nxt
        gripper.command((gx, gy, angle))
        kitchen.step()

    # Hold until no particle can still change the score: a particle is resolved once it is
    # inside the target cup below its rim, or outside the target's span below its rim (it
    # can no longer get in), or at rest. Spill lying on the table is frozen (made static)
    # so it costs nothing while the rest settles.
    elapsed = 0.0
    half = target_spec.width / 2
    inner = target_spec.inner_width / 2
    rim = target_spec.height - 3 * r
    while elapsed < config.max_time:
        gripper.hold(config.check_every * kitchen.config.dt)
        elapsed += config.check_every * kitchen.config.dt
        pos = kitchen.particle_positions()
        on_table = (pos[:, 1] < top + 2.5 * r) & (np.abs(pos[:, 0] - target.position[0]) > half + r)
        freeze(particles, on_table | (pos[:, 1] < top - 1.0))
        resolved = inside_box(pos, target, -inner, inner, target_spec.wall, rim)
        outside = ~inside_box(pos, target, -half, half, -math.inf, rim)
        resolved |= outside & (pos[:, 1] < top + rim)
        resolved |= kitchen.particle_speeds() < config.rest_speed
        if resolved.all():
            break

    pos = kitchen.particle_positions()
    in_target = inside_box(
        pos,
        target,
        -target_spec.inner_width / 2,
        target_spec.inner_width / 2,
        target_spec.wall,
        target_spec.height,
    )
    in_source = inside_box(
        pos,
        held,
        -held_spec.inner_width / 2,
        held_spec.inner_width / 2,
        held_spec.wall,
        held_spec.height,
    )
    fraction = float(np.mean(in_target))
    info = {
        "fraction": fraction,
        "n_particles": len(particles),
        "n_in_target": int(in_target.sum()),
        "n_in_source": int(in_source.sum()),
        "n_elsewhere": int((~in_target & ~in_source).sum()),
        "n_in_world": int(kitchen.in_bounds(pos).sum()),
        "blocked_by_table": blocked,
        "target_shift": float(abs(target.position[0])),
        "sim_time_s": round(kitchen.time, 4),
    }
    return TrialResult(score(fraction), True, info)
