"""Push: slide a block on a table towards a goal, seen from above (no gravity).

Context: the goal position ``goal_x, goal_y`` in [−5, 5] (world units; the block starts at
the origin). Control: the pusher's start ``rx, ry`` in [−5, 5] relative to the block, the
push direction ``angle`` in [0, 2π] and the push ``duration`` in [0, 2] s at ``speed``.
The pusher is the closed gripper seen from above (a disc); the table's friction is modelled
by the block's linear and angular damping. After the push the block slides until it stops.

Score (seed paper): g = 2 − ‖x − x_goal‖ with x the block's final position. A pusher start
overlapping the block is invalid and scores −1. There are no particles in this skill.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ltamp_cli.backends.box2d.kitchenware import BlockSpec, add_body
from ltamp_cli.backends.box2d.skills.common import new_kitchen
from ltamp_cli.backends.box2d.world import Observer, PhysicsConfig
from ltamp_cli.backends.protocol import ParamSpace, SkillSpec, TrialResult

SPEC = SkillSpec(
    name="push",
    context=ParamSpace(("goal_x", "goal_y"), (-5.0, -5.0), (5.0, 5.0), ("units", "units")),
    control=ParamSpace(
        ("rx", "ry", "angle", "duration"), (-5.0, -5.0, 0.0, 0.0), (5.0, 5.0, 2 * math.pi, 2.0),
        ("units", "units", "rad", "s"),
    ),
    description="push a block to a goal seen from above; g = 2 - |x - goal|",
)


@dataclass(frozen=True)
class PushConfig:
    """Simulation settings of a push trial."""

    block: BlockSpec = field(default_factory=BlockSpec)
    pusher_radius: float = 0.4
    speed: float = 4.0
    max_slide_time: float = 4.0
    rest_speed: float = 0.01


def score(distance: float) -> float:
    return 2.0 - distance


def valid_mask(context: np.ndarray, controls: np.ndarray, config: PushConfig) -> np.ndarray:
    """Whether the pusher disc starts clear of the block, for a batch ``(n, 4)``."""
    half = config.block.size / 2
    dx = np.maximum(np.abs(controls[:, 0]) - half, 0.0)
    dy = np.maximum(np.abs(controls[:, 1]) - half, 0.0)
    return np.hypot(dx, dy) > config.pusher_radius + 0.01


def run(
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    config: PushConfig,
    observer: Observer | None = None,
) -> TrialResult:
    """Simulate one push. Nothing here is random, so ``seed`` does not change the outcome."""
    del seed
    if not valid_mask(context, control[None, :], config)[0]:
        return TrialResult(SPEC.invalid_score, False, {"reason": "pusher starts in the block"})
    rx, ry, angle, duration = (float(v) for v in control)
    kitchen = new_kitchen(observer, furniture=False, config=PhysicsConfig(gravity=(0.0, 0.0)))
    block = add_body(
        kitchen,
        config.block.boxes(),
        (0.0, 0.0, 0.0),
        name="block",
        density=config.block.density,
        friction=0.5,
        color=(200, 80, 60),
    )
    block.linearDamping = config.block.linear_damping
    block.angularDamping = config.block.angular_damping
    goal = kitchen.world.CreateStaticBody(position=(float(context[0]), float(context[1])))
    goal.CreateCircleFixture(radius=0.15, isSensor=True)
    goal.userData = {"name": "goal", "color": (40, 170, 60)}
    pusher = kitchen.world.CreateKinematicBody(position=(rx, ry))
    pusher.CreateCircleFixture(radius=config.pusher_radius, friction=0.5)
    pusher.userData = {"name": "gripper", "color": (230, 190, 40)}

    velocity = (config.speed * math.cos(angle), config.speed * math.sin(angle))
    pusher.linearVelocity = velocity
    kitchen.step(round(duration / kitchen.config.dt))
    pusher.linearVelocity = (0.0, 0.0)
    for _ in range(round(config.max_slide_time / kitchen.config.dt)):
        if block.linearVelocity.length < config.rest_speed:
            break
        kitchen.step()
    final = np.array(tuple(block.position))
    distance = float(np.linalg.norm(final - np.asarray(context, dtype=float)))
    info = {
        "distance": distance,
        "final_x": float(final[0]),
        "final_y": float(final[1]),
        "sim_time_s": round(kitchen.time, 4),
    }
    return TrialResult(score(distance), True, info)
