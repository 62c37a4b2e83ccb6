"""Scoop: lower a held spoon into a cup of grains, sweep, turn it upright, lift and balance.

The motion follows the reference Kitchen2D scoop: the spoon visits three waypoints inside
the cup and turns clockwise between the 2nd and the 3rd, so that it cuts through the grains
mouth-first and then carries them mouth-up; at the exit above the rim it is held still until
no grain leaves the spoon any more (the "balance" phase). Our spoon is a ladle (its handle
rises from the bowl's wall, parallel to the mouth), so it is tilted ``turn`` counter-
clockwise (mouth up-left) at waypoints 1 and 2 and upright at waypoint 3; the reference's
side-mouthed spoon turned π/2 from handle-up to handle-level instead. Every motion is
acceleration-limited and stops at every waypoint (:mod:`ltamp_cli.motion.timing`).

Context: ``cup_width`` in [5, 10] and ``cup_height`` in [4, 8] of the cup on the table,
filled 1.5 deep with grains (the reference's grains have radius 0.05, ~1,000 of them fill a
mid-sized cup; by default grains of radius 0.1, a quarter as many). The reference fills a
fixed 1,000 grains whatever the cup, which leaves wide cups a bed shallower than our ladle's
bowl: no control could scoop there. Control:
``grasp_ratio`` in [0, 1] (grasp height on the spoon handle) and three waypoints ``(x_i,
y_i)`` of the spoon bowl's bottom centre, as fractions of the cup's interior: ``x_i`` in
[−1, 1] spans the widest range that keeps the (tilted) spoon clear of the walls and ``y_i``
in [0, 1] runs from ``floor_gap`` above the cup floor to a bowl's depth above the bed. The
spoon enters straight down above waypoint 1 and leaves straight up above waypoint 3.

Score (seed paper; the reference's grain count): x = (grains in the spoon − grains spilled
out of the cup, i.e. now beside it on the table or the floor) / capacity, clipped to [0, 1],
and 0 while a grain in the spoon is still inside the cup (the spoon did not get out);
g = x − 0.5. A path along which the gripper or
the spoon would hit the cup or the table (densely checked, rotations included) is invalid
and scores −1.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace

import numpy as np

from ltamp_cli.backends.box2d.geometry import any_overlap
from ltamp_cli.backends.box2d.gripper import Gripper, GripperSpec
from ltamp_cli.backends.box2d.kitchenware import CupSpec, SpoonSpec, add_cup, add_spoon
from ltamp_cli.backends.box2d.particles import ParticleSpec, add_particles, inside_box
from ltamp_cli.backends.box2d.skills.common import new_kitchen
from ltamp_cli.backends.box2d.world import KitchenLayout, Observer
from ltamp_cli.backends.protocol import ParamSpace, SkillSpec, TrialResult
from ltamp_cli.motion.timing import MotionLimits, planar_limits, time_path

SPEC = SkillSpec(
    name="scoop",
    context=ParamSpace(("cup_width", "cup_height"), (5.0, 4.0), (10.0, 8.0),
                       ("units", "units")),
    control=ParamSpace(
        ("grasp_ratio", "x1", "y1", "x2", "y2", "x3", "y3"),
        (0.0, -1.0, 0.0, -1.0, 0.0, -1.0, 0.0),
        (1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0),
        ("",) * 7,  # fractions of the grasp range and of the cup's interior
    ),
    description="scoop grains from a cup with a spoon; g = (in spoon - spilled)/capacity - 0.5",
)


@dataclass(frozen=True)
class ScoopConfig:
    """Simulation settings of a scoop trial (lengths in world units, times in s).

    The cup is filled ``fill_depth`` deep (as many grains as cover ``fill_depth`` times
    the cup's inner width at hexagonal packing). ``turn`` (rad) is the spoon's tilt at
    waypoints 1 and 2. ``limits`` bound the hand's speed and acceleration (translation
    u/s, u/s²; rotation rad/s, rad/s²) in the grains; the entry and the exit (above the
    bed) go at up to ``air_speed`` (u/s). The balance phase holds the spoon still in
    ``balance_step`` chunks until no grain leaves it (at most ``balance_rounds``).
    """

    particle: ParticleSpec = field(
        default_factory=lambda: ParticleSpec(radius=0.1, color=(230, 120, 170))
    )
    spoon: SpoonSpec = field(default_factory=SpoonSpec)
    wall: float = 0.2
    fill_depth: float = 1.5
    turn: float = math.pi / 12
    limits: MotionLimits = field(default_factory=lambda: planar_limits(1.0, 1.0, 5.0, 2.0))
    air_speed: float = 2.5
    settle_time: float = 0.6
    balance_step: float = 0.25
    balance_rounds: int = 8
    margin: float = 0.5
    max_force: float = 200.0
    max_torque: float = 200.0
    floor_gap: float = 0.3
    check_step: float = 0.05
    gripper: GripperSpec = field(default_factory=GripperSpec)
    layout: KitchenLayout = field(default_factory=KitchenLayout)


def reference_config() -> ScoopConfig:
    """The reference Kitchen2D grains: radius 0.05 (4× the default's count for the same bed)."""
    return replace(ScoopConfig(), particle=ParticleSpec(radius=0.05, color=(230, 120, 170)))


def score(fraction: float) -> float:
    return fraction - 0.5


def capacity(config: ScoopConfig) -> int:
    """How many grains the spoon's cavity holds at hexagonal packing."""
    spoon, r = config.spoon, config.particle.radius
    return max(1, math.floor(spoon.inner_width * spoon.inner_depth / (2 * math.sqrt(3) * r * r)))


def grasp_height(config: ScoopConfig, ratio: float) -> float:
    spoon = config.spoon
    low = spoon.bowl_depth + 0.5
    return low + float(np.clip(ratio, 0.0, 1.0)) * (spoon.bowl_depth + spoon.handle_length - low)


def spoon_poses(context: np.ndarray, control: np.ndarray, config: ScoopConfig) -> np.ndarray:
    """Spoon poses ``(x, y, angle)`` in the world at the entry above waypoint 1, the three
    waypoints and the exit above waypoint 3. ``control`` ``(7,)`` gives ``(5, 3)``;
    ``(n, 7)`` gives ``(n, 5, 3)``."""
    controls = np.atleast_2d(control)
    cup = CupSpec(float(context[0]), float(context[1]), config.wall)
    top = config.layout.table_top
    sp = config.spoon
    # Keep a grain's diameter under the bowl: crushing grains against the cup's floor
    # with an unstoppable (kinematic) spoon makes Box2D eject them.
    # Waypoints span the bed: from ``floor_gap`` above the floor to a bowl's depth above the
    # bed's surface (higher, the spoon sweeps through air).
    low = cup.wall + config.floor_gap
    high = min(cup.height, cup.wall + config.fill_depth + sp.bowl_depth)
    angles = np.array([config.turn, config.turn, 0.0])
    # The (tilted) spoon's extent around its origin, so every waypoint fraction keeps the
    # bowl and the leaning handle inside the cup: box corners turned by each angle.
    cx = np.array([b.cx + sx * b.hw for b in sp.boxes() for sx in (-1, 1) for _ in (0, 1)])
    cy = np.array([b.cy + sy * b.hh for b in sp.boxes() for _ in (0, 1) for sy in (-1, 1)])
    turned_x = np.cos(angles)[:, None] * cx - np.sin(angles)[:, None] * cy
    turned_y = np.sin(angles)[:, None] * cx + np.cos(angles)[:, None] * cy
    left = -cup.inner_width / 2 + config.margin - turned_x.min(axis=1)
    right = cup.inner_width / 2 - config.margin - turned_x.max(axis=1)
    xs = (left + right) / 2 + controls[:, 1::2] * (right - left) / 2
    ys = top + low - turned_y.min(axis=1) + controls[:, 2::2] * (high - low)
    above = np.full(len(controls), top + cup.height + 0.5)
    px = np.stack([xs[:, 0], xs[:, 0], xs[:, 1], xs[:, 2], xs[:, 2]], axis=1)
    py = np.stack([above, ys[:, 0], ys[:, 1], ys[:, 2], above + 0.5], axis=1)
    angles = np.broadcast_to(np.array([0.0, config.turn, config.turn, 0.0, 0.0]), px.shape)
    poses = np.stack([px, py, angles], axis=-1)
    return poses[0] if np.ndim(control) == 1 else poses


def waypoints(context: np.ndarray, control: np.ndarray, config: ScoopConfig) -> np.ndarray:
    """Spoon-origin positions of :func:`spoon_poses`: ``(5, 2)`` or ``(n, 5, 2)``. The
    entry and the exit are upright, so hand = spoon + grasp offset there."""
    return spoon_poses(context, control, config)[..., :2]


def hand_poses(spoon: np.ndarray, grasp: tuple[float, float]) -> np.ndarray:
    """Hand poses ``(..., 3)`` holding the spoon at ``spoon`` ``(..., 3)`` by ``grasp``
    (the hand's origin in the spoon frame)."""
    c, s = np.cos(spoon[..., 2]), np.sin(spoon[..., 2])
    return np.stack([spoon[..., 0] + c * grasp[0] - s * grasp[1],
                     spoon[..., 1] + s * grasp[0] + c * grasp[1], spoon[..., 2]], axis=-1)


def hand_path(context: np.ndarray, control: np.ndarray, config: ScoopConfig) -> np.ndarray:
    """Hand poses ``(5, 3)`` of one control (cup at the origin of the table)."""
    grasp = (config.spoon.handle_x, grasp_height(config, float(control[0])))
    return hand_poses(spoon_poses(context, control, config), grasp)


def _rotated_aabbs(boxes: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """AABBs ``(n, k, 4)`` of boxes ``(k, 4)`` (cx, cy, hw, hh in a frame) at ``poses``
    ``(n, 3)`` (conservative for rotated boxes)."""
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    cx = poses[:, :1] + c * boxes[None, :, 0] - s * boxes[None, :, 1]
    cy = poses[:, 1:2] + s * boxes[None, :, 0] + c * boxes[None, :, 1]
    ex = np.abs(c) * boxes[None, :, 2] + np.abs(s) * boxes[None, :, 3]
    ey = np.abs(s) * boxes[None, :, 2] + np.abs(c) * boxes[None, :, 3]
    return np.stack([cx - ex, cy - ey, cx + ex, cy + ey], axis=-1)


def valid_mask(context: np.ndarray, controls: np.ndarray, config: ScoopConfig) -> np.ndarray:
    """Collision test of the whole path (spoon and gripper against the cup and the table,
    sampled every ``check_step`` units or radians) for a batch ``(n, 7)``; ``(n,)`` bools."""
    controls = np.atleast_2d(np.asarray(controls, dtype=float))
    cup = CupSpec(float(context[0]), float(context[1]), config.wall)
    lay = config.layout
    top = lay.table_top
    fixed = np.array([[b.cx - b.hw, b.cy - b.hh + top, b.cx + b.hw, b.cy + b.hh + top]
                      for b in cup.boxes()]
                     + [[lay.table_x0, top - lay.table_thickness, lay.table_x1, top]])
    poses = spoon_poses(context, controls, config)  # (n, 5, 3)
    spoon_boxes = np.array([[b.cx, b.cy, b.hw, b.hh] for b in config.spoon.boxes()])
    gripper_boxes = np.array([[b.cx, b.cy, b.hw, b.hh]
                              for b in config.gripper.boxes(config.spoon.wall)])
    ok = np.ones(len(controls), dtype=bool)
    for i, control in enumerate(controls):
        grasp = (config.spoon.handle_x, grasp_height(config, float(control[0])))
        hands = hand_poses(poses[i], grasp)
        dense = [hands[:1]]
        for a, b in itertools.pairwise(hands):
            # A turn moves the far end of gripper + handle (~12 units out) the most.
            k = max(1, math.ceil(max(np.hypot(*(b[:2] - a[:2])), abs(b[2] - a[2]) * 12)
                                 / config.check_step))
            dense.append(a + np.linspace(0, 1, k + 1)[1:, None] * (b - a))
        hand = np.concatenate(dense)
        spoon = hand.copy()
        c, s = np.cos(hand[:, 2]), np.sin(hand[:, 2])
        spoon[:, 0] = hand[:, 0] - (c * grasp[0] - s * grasp[1])
        spoon[:, 1] = hand[:, 1] - (s * grasp[0] + c * grasp[1])
        movers = np.concatenate([_rotated_aabbs(spoon_boxes, spoon),
                                 _rotated_aabbs(gripper_boxes, hand)], axis=1)
        ok[i] = not any_overlap(movers, np.broadcast_to(fixed, (len(hand), *fixed.shape)),
                                margin=0.01).any()
    return ok


def fill_count(cup: CupSpec, config: ScoopConfig) -> int:
    """Grains filling ``cup`` ``fill_depth`` deep at hexagonal packing (at least one row)."""
    r = config.particle.radius
    per_row = math.floor((cup.inner_width - 2 * r) / (2.02 * r)) + 1
    area = config.fill_depth * cup.inner_width
    return max(per_row, round(area / (2 * math.sqrt(3) * r * r)))


def grain_grid(x0: float, x1: float, y0: float, n: int, radius: float,
               rng: np.random.Generator) -> np.ndarray:
    """``n`` grain centres ``(n, 2)`` on a loose square grid (pitch 2.3 radii, jittered by
    a tenth of a radius) from ``y0`` up between ``x0`` and ``x1``, as the reference fills
    its cups. Settling makes the bed disordered: a perfect hexagonal packing of
    frictionless grains is rigid, and a spoon pushed into it squeezes grains out at
    several units per second along the walls."""
    pitch = 2.3 * radius
    per_row = math.floor((x1 - x0 - 2 * radius) / pitch) + 1
    index = np.arange(n)
    spare = x1 - x0 - 2 * radius - (per_row - 1) * pitch
    xs = x0 + radius + spare / 2 + (index % per_row) * pitch
    ys = y0 + radius + (index // per_row) * pitch
    jitter = rng.uniform(-0.1 * radius, 0.1 * radius, size=(n, 2))
    return np.stack([xs, ys], axis=1) + jitter


def timed_hands(hands: np.ndarray, config: ScoopConfig, dt: float) -> np.ndarray:
    """The commanded hand poses ``(m, 3)`` of :func:`execute_scoop`, one per step ``dt``:
    the entry and the exit segments at ``air_speed``, the rest at ``config.limits``."""
    lim = config.limits
    air = replace(lim, speeds=(config.air_speed, *lim.speeds[1:]))
    pieces = [time_path(hands[:2], air, dt)[1:], time_path(hands[1:4], lim, dt)[1:],
              time_path(hands[3:], air, dt)[1:]]
    return np.concatenate(pieces, axis=0)


def execute_scoop(gripper: Gripper, hands: np.ndarray, config: ScoopConfig) -> None:
    """Drive the hand (holding the spoon) from the entry through ``hands`` ``(5, 3)`` (world
    poses: entry, waypoints, exit), then the balance phase: hold still until the grains in
    the spoon stop changing. Shared by the trials and the plan executor."""
    kitchen = gripper.kitchen
    spoon = gripper.held
    if config.max_force > 0:
        gripper.hold_dynamically(config.max_force, config.max_torque)
    gripper.track(timed_hands(hands, config, kitchen.config.dt))
    sp = config.spoon
    last = -1
    for _ in range(config.balance_rounds):
        gripper.hold(config.balance_step)
        pos = kitchen.particle_positions()
        count = int(inside_box(pos, spoon, -sp.inner_width / 2, sp.inner_width / 2, sp.wall,
                               sp.bowl_depth).sum()) if len(pos) else 0
        if count == last:
            break
        last = count
    gripper.hold_rigidly()


def run(
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    config: ScoopConfig,
    observer: Observer | None = None,
) -> TrialResult:
    """Simulate one scoop; deterministic given ``seed`` (it jitters grain starts)."""
    if not valid_mask(context, control[None, :], config)[0]:
        return TrialResult(SPEC.invalid_score, False, {"reason": "path hits the cup"})
    cup_spec = CupSpec(float(context[0]), float(context[1]), config.wall)
    top = config.layout.table_top
    kitchen = new_kitchen(observer, layout=config.layout)
    cup = add_cup(kitchen, cup_spec, (0.0, top, 0.0), name="cup")
    hands = hand_path(context, control, config)
    start = spoon_poses(context, control, config)[0]
    spoon = add_spoon(kitchen, config.spoon, tuple(start))
    gripper = Gripper(kitchen, tuple(hands[0]), config.spoon.wall, config.gripper)
    if not gripper.grasp(spoon):  # pragma: no cover - geometry guarantees finger contact
        raise RuntimeError("scoop: gripper failed to grasp the spoon")

    rng = np.random.default_rng(seed)
    inner = cup_spec.inner_width / 2
    n = fill_count(cup_spec, config)
    points = grain_grid(-inner, inner, top + cup_spec.wall, n, config.particle.radius, rng)
    particles = add_particles(kitchen, points, config.particle)
    gripper.hold(config.settle_time)
    in_cup_before = inside_box(kitchen.particle_positions(), cup, -inner, inner,
                               cup_spec.wall, cup_spec.height + 5.0)
    execute_scoop(gripper, hands, config)

    pos = kitchen.particle_positions()
    sp = config.spoon
    in_spoon = inside_box(
        pos, spoon, -sp.inner_width / 2, sp.inner_width / 2, sp.wall, sp.bowl_depth
    )
    in_cup = inside_box(pos, cup, -inner, inner, cup_spec.wall, cup_spec.height)
    # Spilled: out of the cup's column (on the table or the floor). Grains above the cup
    # (heaped on the spoon, or falling back in) are not.
    column = inside_box(pos, cup, -cup_spec.width / 2, cup_spec.width / 2, 0.0, np.inf)
    spilled = in_cup_before & ~column & ~in_spoon
    stuck = bool((in_spoon & in_cup).any())
    cap = capacity(config)
    raw = (float(in_spoon.sum()) - float(spilled.sum())) / cap
    fraction = 0.0 if stuck else float(np.clip(raw, 0.0, 1.0))
    info = {
        "fraction": fraction,
        "capacity": cap,
        "n_particles": len(particles),
        "n_in_spoon": int(in_spoon.sum()),
        "n_in_cup": int(in_cup.sum()),
        "n_spilled": int(spilled.sum()),
        "n_elsewhere": int((~in_spoon & ~in_cup).sum()),
        "n_in_world": int(kitchen.in_bounds(pos).sum()),
        "cup_shift": float(abs(cup.position[0])),
        "sim_time_s": round(kitchen.time, 4),
    }
    return TrialResult(score(fraction), True, info)
