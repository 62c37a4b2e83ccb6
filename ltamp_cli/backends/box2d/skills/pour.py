"""Pour: carry a held cup of particles to a pour pose and tilt it over a target cup.

The skill as the reference Kitchen2D defines it (field facts):

* Context (world units): ``cup_width, cup_height`` of the held (pouring) cup and
  ``target_width, target_height`` of the target cup; widths in [3, 8], heights in [3, 5].
* Control: ``grasp_ratio`` in [0, 1] (grasp height on the held cup's handle bar, as a
  fraction of its height), ``rel_x`` in [−10, 10] and ``rel_y`` in [1, 10] (the pour pose:
  the grasp point relative to the centre of the target cup's rim) and ``dangle`` in
  [π/2, π] (final tilt). The tilt's sense is ``sign(rel_x)``: the cup always tips towards
  the target, clockwise from its left (``rel_x ≤ 0``), anticlockwise from its right.
* Initial state: the held cup, full of particles, stands ``clearance`` above the table with
  the grasp point ``carry_from`` = (−15, 0) from the target's centre (x) and the table
  (y, plus the grasp height). The gripper carries it up, across above everything and
  down to the pour pose, each leg rest-to-rest with a minimum-jerk profile whose duration
  respects ``carry_speed`` and ``carry_accel`` (``motion.timing.min_jerk``), then tilts at
  ``rotate_speed`` and holds until no particle can still change the score, or
  ``max_time`` after the tilt.
* Validity: the start, the pour pose and the whole tilt must keep the gripper and the held
  cup clear of the target cup and the table; otherwise the trial scores −1 without
  simulating ("illegal start/tilt collision").

Score (seed paper): g = exp(2(10x − 9.5)) − 1 with x the fraction of the particles inside
the target cup, so g > 0 iff x > 0.95.

:data:`REFERENCE` is the reference implementation's setting (500 particles, tilt 0.1 rad/s,
30 s cap); :class:`PourConfig`'s defaults are the fast setting ``bench/fidelity.py`` (row
``2d-pour-reference``) compares with it.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from ltamp_cli.backends.box2d.geometry import Box, rotated_hits
from ltamp_cli.backends.box2d.gripper import Gripper, GripperSpec
from ltamp_cli.backends.box2d.kitchenware import CupSpec, add_cup
from ltamp_cli.backends.box2d.particles import ParticleSpec, add_particles, hex_grid, inside_box
from ltamp_cli.backends.box2d.skills.common import freeze, new_kitchen
from ltamp_cli.backends.box2d.world import KitchenLayout, Observer
from ltamp_cli.backends.protocol import ParamSpace, SkillSpec, TrialResult
from ltamp_cli.motion.timing import min_jerk

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
    description="carry a full cup and tip it into a target cup; g = exp(2(10x-9.5)) - 1",
)

#: Tilt angles at which :func:`valid_mask` checks the swing (0 and the final tilt included).
SWING_ANGLES = 49
#: Fixed boxes are grown by this much in the swing check: between two checked angles a far
#: corner of the held cup moves up to ~0.6 units, more than a 0.2 wall is thick.
SWING_MARGIN = 0.2


@dataclass(frozen=True)
class PourConfig:
    """Simulation settings of a pour trial (lengths in world units, times in s).

    The defaults are the fast setting; :data:`REFERENCE` is the reference one.
    """

    n_particles: int = 100
    particle: ParticleSpec = field(default_factory=ParticleSpec)
    wall: float = 0.2
    #: Tilt speed (rad/s).
    rotate_speed: float = 0.25
    #: Cap on the hold after the tilt (s).
    max_time: float = 10.0
    settle_time: float = 0.3
    rest_speed: float = 0.05
    check_every: int = 10
    #: Start of the grasp point relative to the target's centre (x) and the table top plus
    #: the grasp height and ``clearance`` (y).
    carry_from: tuple[float, float] = (-15.0, 0.0)
    clearance: float = 0.1
    #: Height the carried cup's bottom keeps above the target's rim while crossing.
    carry_margin: float = 1.0
    #: Speed (units/s) and acceleration (units/s²) limits of the carry.
    carry_speed: float = 10.0
    carry_accel: float = 8.0
    gripper: GripperSpec = field(default_factory=GripperSpec)
    layout: KitchenLayout = field(default_factory=KitchenLayout)


#: The reference Kitchen2D's pour: 500 particles, tilt at 0.1 rad/s, 30 s cap.
REFERENCE = PourConfig(n_particles=500, rotate_speed=0.1, max_time=30.0)


def score(fraction: float) -> float:
    return math.exp(2.0 * (10.0 * fraction - 9.5)) - 1.0


def tilt_sign(rel_x: float | np.ndarray) -> float | np.ndarray:
    """Sense of the tilt (+1 anticlockwise): towards the target, i.e. ``sign(rel_x)``, with
    ``rel_x = 0`` tilting clockwise (the handle side is the left)."""
    return np.where(np.asarray(rel_x) > 0, 1.0, -1.0) if np.ndim(rel_x) else (
        1.0 if rel_x > 0 else -1.0)


def _cups(context: np.ndarray, config: PourConfig) -> tuple[CupSpec, CupSpec]:
    cw1, ch1, cw2, ch2 = (float(v) for v in context)
    return CupSpec(cw1, ch1, config.wall), CupSpec(cw2, ch2, config.wall)


def _moving_boxes(held: CupSpec, grasp_height: float, config: PourConfig) -> list[Box]:
    """Gripper and held-cup boxes in the gripper frame (origin: the grasp point)."""
    ox, oy = -held.handle_x, -grasp_height
    cup = [Box(b.cx + ox, b.cy + oy, b.hw, b.hh) for b in held.boxes()]
    return [*config.gripper.boxes(held.handle_width), *cup]


def _fixed_boxes(target: CupSpec, config: PourConfig) -> np.ndarray:
    """Target cup and table as ``(xmin, ymin, xmax, ymax)`` rows, shape ``(k, 4)``."""
    lay = config.layout
    top = lay.table_top
    rows = [[b.cx - b.hw, top + b.cy - b.hh, b.cx + b.hw, top + b.cy + b.hh]
            for b in target.boxes()]
    rows.append([lay.table_x0, top - lay.table_thickness, lay.table_x1, top])
    return np.array(rows)


def valid_mask(context: np.ndarray, controls: np.ndarray, config: PourConfig) -> np.ndarray:
    """Start, pour-pose and tilt collision test for a batch of controls ``(n, 4)``.

    The carry starts clear of everything by construction and crosses above the target, and
    its last leg is vertical, so a clear pour pose means a clear carry. The tilt is checked
    at :data:`SWING_ANGLES` angles with the fixed boxes grown by :data:`SWING_MARGIN`.
    Returns ``(n,)`` bools.
    """
    held, target = _cups(context, config)
    top = config.layout.table_top
    fixed = _fixed_boxes(target, config)
    controls = np.asarray(controls, dtype=float).reshape(-1, 4)
    heights = np.array([held.grasp_height(float(r)) for r in controls[:, 0]])
    # Moving boxes in the gripper frame: the gripper's do not depend on the grasp, the held
    # cup's are lowered by the grasp height. Centres (n, b, 2), half extents (b, 2).
    gripper = [*config.gripper.boxes(held.handle_width)]
    cup = _moving_boxes(held, 0.0, config)[len(gripper):]
    local = np.array([[b.cx, b.cy] for b in (*gripper, *cup)])
    drop = np.zeros((len(controls), len(local), 2))
    drop[:, len(gripper):, 1] = heights[:, None]
    centers = local[None] - drop
    half = np.array([[b.hw, b.hh] for b in (*gripper, *cup)])
    grasp = np.stack([controls[:, 1], top + target.height + controls[:, 2]], axis=-1)  # (n, 2)
    angles = (tilt_sign(controls[:, 1]) * controls[:, 3])[:, None] * np.linspace(
        0.0, 1.0, SWING_ANGLES)[None, :]  # (n, A)
    c, s = np.cos(angles)[..., None], np.sin(angles)[..., None]  # (n, A, 1)
    px, py = centers[:, None, :, 0], centers[:, None, :, 1]  # (n, 1, b)
    world = np.stack([grasp[:, None, None, 0] + c * px - s * py,
                      grasp[:, None, None, 1] + s * px + c * py], axis=-1)  # (n, A, b, 2)
    box_angles = np.broadcast_to(angles[..., None], world.shape[:-1])
    start = rotated_hits(world[:, 0], box_angles[:, 0], half, fixed, 0.01).any(axis=-1)
    swing = rotated_hits(world[:, 1:], box_angles[:, 1:], half, fixed,
                         SWING_MARGIN).any(axis=(1, 2))
    return ~(start | swing)


def carry_waypoints(context: np.ndarray, control: np.ndarray, config: PourConfig
                    ) -> list[tuple[float, float]]:
    """Grasp-point positions of the carry: start, lifted, across, pour pose (world units).

    The cup crosses with its bottom ``carry_margin`` above the target's rim (or higher if
    the pour pose is), so the carry never meets the target.
    """
    held, target = _cups(context, config)
    top = config.layout.table_top
    gh = held.grasp_height(float(control[0]))
    start = (config.carry_from[0], top + config.carry_from[1] + config.clearance + gh)
    goal = (float(control[1]), top + target.height + float(control[2]))
    cross = max(goal[1], top + target.height + config.carry_margin + gh)
    path = [start, (start[0], cross), (goal[0], cross), goal]
    return [p for i, p in enumerate(path) if i == 0 or p != path[i - 1]]


def run(
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    config: PourConfig,
    observer: Observer | None = None,
) -> TrialResult:
    """Simulate one pour; deterministic given ``seed`` (it only jitters particle starts)."""
    if not valid_mask(context, control[None, :], config)[0]:
        return TrialResult(SPEC.invalid_score, False, {"reason": "colliding start or tilt"})
    held_spec, target_spec = _cups(context, config)
    ratio, rel_x, _rel_y, dangle = (float(v) for v in control)
    top = config.layout.table_top
    kitchen = new_kitchen(observer, layout=config.layout)
    target = add_cup(kitchen, target_spec, (0.0, top, 0.0), name="target")
    path = carry_waypoints(context, control, config)
    (sx, sy), (gx, gy) = path[0], path[-1]
    gh = held_spec.grasp_height(ratio)
    cx = sx - held_spec.handle_x
    held = add_cup(kitchen, held_spec, (cx, sy - gh, 0.0), name="held", kind="dynamic")
    gripper = Gripper(kitchen, (sx, sy, 0.0), held_spec.handle_width, config.gripper)
    if not gripper.grasp(held):  # pragma: no cover - geometry guarantees finger contact
        raise RuntimeError("pour: gripper failed to grasp the held cup")

    rng = np.random.default_rng(seed)
    r = config.particle.radius
    inner = held_spec.inner_width / 2
    points = hex_grid(cx - inner, cx + inner, sy - gh + held_spec.wall, config.n_particles, r, rng)
    if points[:, 1].max() + r > sy - gh + held_spec.height:
        raise ValueError("pour: the particles do not fit in the held cup")
    particles = add_particles(kitchen, points, config.particle)
    gripper.hold(config.settle_time)

    # Carry: rest-to-rest minimum-jerk legs (the grains slosh as they would in a real carry).
    dt = kitchen.config.dt
    for (x0, y0), (x1, y1) in itertools.pairwise(path):
        for f in min_jerk(math.hypot(x1 - x0, y1 - y0), config.carry_speed, config.carry_accel,
                          dt):
            gripper.command((x0 + f * (x1 - x0), y0 + f * (y1 - y0), 0.0))
            kitchen.step()

    # A particle is resolved once it is inside the target cup below its rim, or out of the
    # held cup, outside the target's span and below its rim (it can no longer get in).
    # Spill on the table is frozen (made static) so it costs nothing while the rest settles.
    half = target_spec.width / 2
    inner = target_spec.inner_width / 2
    rim = target_spec.height - 3 * r
    source_half = held_spec.inner_width / 2 + r

    def resolved_by_place() -> np.ndarray:
        pos = kitchen.particle_positions()
        on_table = (pos[:, 1] < top + 2.5 * r) & (np.abs(pos[:, 0] - target.position[0]) > half + r)
        freeze(particles, on_table | (pos[:, 1] < top - 1.0))
        done = inside_box(pos, target, -inner, inner, target_spec.wall, rim)
        outside = ~inside_box(pos, target, -half, half, -math.inf, rim)
        outside &= ~inside_box(pos, held, -source_half, source_half, 0.0, held_spec.height + r)
        return done | (outside & (pos[:, 1] < top + rim))

    # Tilt towards the target; stop early once every particle is resolved (nothing left
    # to pour, so the rest of the tilt cannot change the score).
    sense = tilt_sign(rel_x)
    step_angle = config.rotate_speed * dt
    n_steps = math.ceil(dangle / step_angle - 1e-9)
    poured_out = False
    for k in range(1, n_steps + 1):
        gripper.command((gx, gy, sense * min(k * step_angle, dangle)))
        kitchen.step()
        if k % config.check_every == 0 and resolved_by_place().all():
            poured_out = True
            break

    elapsed = 0.0
    while not poured_out and elapsed < config.max_time:
        gripper.hold(config.check_every * dt)
        elapsed += config.check_every * dt
        if (resolved_by_place() | (kitchen.particle_speeds() < config.rest_speed)).all():
            break

    pos = kitchen.particle_positions()
    in_target = inside_box(pos, target, -inner, inner, target_spec.wall, target_spec.height)
    in_source = inside_box(pos, held, -held_spec.inner_width / 2, held_spec.inner_width / 2,
                           held_spec.wall, held_spec.height)
    fraction = float(np.mean(in_target))
    info = {
        "fraction": fraction,
        "n_particles": len(particles),
        "n_in_target": int(in_target.sum()),
        "n_in_source": int(in_source.sum()),
        "n_elsewhere": int((~in_target & ~in_source).sum()),
        "n_in_world": int(kitchen.in_bounds(pos).sum()),
        "target_shift": float(abs(target.position[0])),
        "sim_time_s": round(kitchen.time, 4),
    }
    return TrialResult(score(fraction), True, info)
