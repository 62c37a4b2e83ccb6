"""Scoop: move a held spoon through three waypoints inside a cup of particles, lift it out.

Context: ``cup_width`` in [5, 10] and ``cup_height`` in [4, 8] of the cup standing on the
table (filled ``fill_depth`` deep). Control: ``grasp_ratio`` in [0, 1] (grasp height on the
spoon handle) and three waypoints ``(x_i, y_i)`` of the spoon bowl's bottom centre, as
fractions of the cup's interior: ``x_i`` in [−1, 1] spans the widest bowl-in-cup range and
``y_i`` in [0, 1] runs from a grain's diameter above the cup floor to the rim. The spoon
enters straight down above waypoint 1, visits 1 → 2 → 3 and leaves straight up. The spoon
(size and shape) is fixed.

Score (seed paper): g = x − 0.5 with x the filled fraction of the spoon's capacity (hexagonal
packing of the bowl cavity), capped at 1. A path along which the gripper or spoon would hit
the cup or the table (swept boxes; the spoon never rotates) is invalid and scores −1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from itertools import pairwise

import numpy as np

from ltamp_cli.backends.box2d.geometry import aabbs, any_overlap, sweep
from ltamp_cli.backends.box2d.gripper import Gripper, GripperSpec
from ltamp_cli.backends.box2d.kitchenware import CupSpec, SpoonSpec, add_cup, add_spoon
from ltamp_cli.backends.box2d.particles import ParticleSpec, add_particles, hex_grid, inside_box
from ltamp_cli.backends.box2d.skills.common import new_kitchen
from ltamp_cli.backends.box2d.world import KitchenLayout, Observer
from ltamp_cli.backends.protocol import ParamSpace, SkillSpec, TrialResult

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
    description="scoop particles from a cup with a spoon; g = filled fraction - 0.5",
)


@dataclass(frozen=True)
class ScoopConfig:
    """Simulation settings of a scoop trial.

    Particles are larger than the pour's (radius 0.1) so that a cup filled ``fill_depth``
    deep holds a few hundred of them rather than thousands.
    """

    particle: ParticleSpec = field(
        default_factory=lambda: ParticleSpec(radius=0.1, color=(230, 120, 170))
    )
    spoon: SpoonSpec = field(default_factory=SpoonSpec)
    wall: float = 0.2
    fill_depth: float = 1.5
    speed: float = 1.5
    settle_time: float = 0.3
    hold_time: float = 0.5
    margin: float = 0.05
    gripper: GripperSpec = field(default_factory=GripperSpec)
    layout: KitchenLayout = field(default_factory=KitchenLayout)


def score(fraction: float) -> float:
    return fraction - 0.5


def capacity(config: ScoopConfig) -> int:
    """How many particles the spoon's cavity holds at hexagonal packing."""
    spoon, r = config.spoon, config.particle.radius
    return max(1, math.floor(spoon.inner_width * spoon.inner_depth / (2 * math.sqrt(3) * r * r)))


def grasp_height(config: ScoopConfig, ratio: float) -> float:
    spoon = config.spoon
    low = spoon.bowl_depth + 0.5
    return low + float(np.clip(ratio, 0.0, 1.0)) * (spoon.bowl_depth + spoon.handle_length - low)


def waypoints(context: np.ndarray, control: np.ndarray, config: ScoopConfig) -> np.ndarray:
    """Spoon-origin waypoints in the world: entry above waypoint 1, the three waypoints,
    exit above waypoint 3. ``control`` ``(7,)`` gives ``(5, 2)``; ``(n, 7)`` gives ``(n, 5, 2)``.
    """
    controls = np.atleast_2d(control)
    cup = CupSpec(float(context[0]), float(context[1]), config.wall)
    top = config.layout.table_top
    reach = cup.inner_width / 2 - config.spoon.bowl_width / 2 - config.margin
    # Keep a particle's diameter under the bowl: crushing grains against the cup's floor
    # with an unstoppable (kinematic) spoon makes Box2D eject them.
    low, high = cup.wall + 2.5 * config.particle.radius, cup.height
    xs = controls[:, 1::2] * reach
    ys = top + low + controls[:, 2::2] * (high - low)
    above = np.full(len(controls), top + cup.height + 0.5)
    px = np.stack([xs[:, 0], xs[:, 0], xs[:, 1], xs[:, 2], xs[:, 2]], axis=1)
    py = np.stack([above, ys[:, 0], ys[:, 1], ys[:, 2], above + 0.5], axis=1)
    points = np.stack([px, py], axis=-1)
    return points[0] if np.ndim(control) == 1 else points


def valid_mask(context: np.ndarray, controls: np.ndarray, config: ScoopConfig) -> np.ndarray:
    """Swept-box collision test of the whole path for a batch ``(n, 7)``; ``(n,)`` bools."""
    cup = CupSpec(float(context[0]), float(context[1]), config.wall)
    lay = config.layout
    top = lay.table_top
    n = len(controls)
    fixed = np.concatenate(
        [
            aabbs(cup.boxes(), np.zeros(n), np.full(n, top)),
            np.tile([[[lay.table_x0, top - lay.table_thickness, lay.table_x1, top]]], (n, 1, 1)),
        ],
        axis=1,
    )
    path = waypoints(context, controls, config)  # (n, 5, 2)
    gh = np.array([grasp_height(config, float(c)) for c in controls[:, 0]])
    hx = config.spoon.handle_x
    swept = []
    for k in range(path.shape[1]):
        x, y = path[:, k, 0], path[:, k, 1]
        swept.append(
            np.concatenate(
                [
                    aabbs(config.spoon.boxes(), x, y),
                    aabbs(config.gripper.boxes(config.spoon.wall), x + hx, y + gh),
                ],
                axis=1,
            )
        )
    segments = [sweep(a, b) for a, b in pairwise(swept)]
    return ~any_overlap(np.concatenate(segments, axis=1), fixed, margin=0.01)


def fill_count(cup: CupSpec, config: ScoopConfig) -> int:
    """Particles needed to fill ``cup`` ``fill_depth`` deep (whole hexagonal rows)."""
    r = config.particle.radius
    pitch = 2.02 * r
    per_row = math.floor((cup.inner_width - 2 * r) / pitch) + 1
    rows = max(1, round(config.fill_depth / (pitch * math.sqrt(3) / 2)))
    return per_row * rows - rows // 2


def run(
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    config: ScoopConfig,
    observer: Observer | None = None,
) -> TrialResult:
    """Simulate one scoop; deterministic given ``seed`` (it jitters particle starts)."""
    if not valid_mask(context, control[None, :], config)[0]:
        return TrialResult(SPEC.invalid_score, False, {"reason": "path hits the cup"})
    cup_spec = CupSpec(float(context[0]), float(context[1]), config.wall)
    top = config.layout.table_top
    kitchen = new_kitchen(observer, layout=config.layout)
    cup = add_cup(kitchen, cup_spec, (0.0, top, 0.0), name="cup")
    path = waypoints(context, control, config)
    gh = grasp_height(config, float(control[0]))
    spoon = add_spoon(kitchen, config.spoon, (path[0, 0], path[0, 1], 0.0))
    grasp = (path[0, 0] + config.spoon.handle_x, path[0, 1] + gh, 0.0)
    gripper = Gripper(kitchen, grasp, config.spoon.wall, config.gripper)
    if not gripper.grasp(spoon):  # pragma: no cover - geometry guarantees finger contact
        raise RuntimeError("scoop: gripper failed to grasp the spoon")

    rng = np.random.default_rng(seed)
    inner = cup_spec.inner_width / 2
    n = fill_count(cup_spec, config)
    points = hex_grid(-inner, inner, top + cup_spec.wall, n, config.particle.radius, rng)
    particles = add_particles(kitchen, points, config.particle)
    gripper.hold(config.settle_time)
    for x, y in path[1:]:
        gripper.move((x + config.spoon.handle_x, y + gh, 0.0), speed=config.speed)
    gripper.hold(config.hold_time)

    pos = kitchen.particle_positions()
    sp = config.spoon
    in_spoon = inside_box(
        pos, spoon, -sp.inner_width / 2, sp.inner_width / 2, sp.wall, sp.bowl_depth
    )
    in_cup = inside_box(pos, cup, -inner, inner, cup_spec.wall, cup_spec.height)
    cap = capacity(config)
    fraction = min(1.0, float(in_spoon.sum()) / cap)
    info = {
        "fraction": fraction,
        "capacity": cap,
        "n_particles": len(particles),
        "n_in_spoon": int(in_spoon.sum()),
        "n_in_cup": int(in_cup.sum()),
        "n_elsewhere": int((~in_spoon & ~in_cup).sum()),
        "n_in_world": int(kitchen.in_bounds(pos).sum()),
        "cup_shift": float(abs(cup.position[0])),
        "sim_time_s": round(kitchen.time, 4),
    }
    return TrialResult(score(fraction), True, info)
