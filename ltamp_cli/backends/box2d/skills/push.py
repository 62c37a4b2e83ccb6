"""Push: push a round object on a table towards a goal, seen from above (no gravity).

The skill as the reference Kitchen2D defines it (field facts):

* Context: the goal position ``goal_x, goal_y`` in [−5, 5] (world units; the object starts
  at the origin).
* Control: the pusher's start ``rx, ry`` in [−5, 5] relative to the object, the push
  direction ``angle`` in [0, 2π] and the push ``duration`` in [0, 2] s.
* The object is a disc of radius 1 held to the table by a friction joint (max force 5,
  max torque 2: the table's friction seen from above). The pusher is a 0.6 × 2 rectangle
  (thin along the push, wide across it) driven by force tracking: every step a force
  brings its velocity to ``speed`` (10 units/s) along ``angle``. After ``duration`` it
  tracks zero velocity while the object coasts for ``coast_time`` (1 s, 100 steps).
* Validity: a pusher start overlapping the object scores −1 without simulating.

Score (seed paper): g = 2 − ‖x − x_goal‖ with x the object's position at the end. Nothing
here is random. The trial reports x as its *outcome* (``object_x, object_y``; the protocol's
``OutcomeSpec``): the goal is a pure goal (the push's physics ignores it), so one push's end
position scores that control for every goal (hindsight relabelling,
:mod:`ltamp_cli.learning.outcomes`). The object's density is not among the reference
facts; 0.1 makes it light enough that the friction joint (deceleration 5 / mass ≈ 16
units/s²) stops a push at 10 units/s within the coast (about 3 units), so goals over the
whole box are reachable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from Box2D import b2

from ltamp_cli.backends.box2d.skills.common import new_kitchen
from ltamp_cli.backends.box2d.world import Observer, PhysicsConfig
from ltamp_cli.backends.protocol import OutcomeSpec, ParamSpace, SkillSpec, TrialResult


def outcome_scores(contexts: np.ndarray, controls: np.ndarray,
                   outcomes: np.ndarray) -> np.ndarray:
    """g = 2 − ‖end position − goal‖ for batches: goals ``contexts (n, 2)``, end positions
    ``outcomes (n, 2)`` (world units); ``controls`` are not needed. Returns ``(n,)``."""
    del controls
    return 2.0 - np.linalg.norm(np.asarray(outcomes, dtype=float)
                                - np.asarray(contexts, dtype=float), axis=1)


def achieved_goal(outcomes: np.ndarray) -> np.ndarray:
    """The goal an end position satisfies best: the end position itself, ``(n, 2)``."""
    return np.asarray(outcomes, dtype=float)


OUTCOME = OutcomeSpec(
    space=ParamSpace(("object_x", "object_y"), (-10.0, -10.0), (10.0, 10.0), ("units", "units")),
    score=outcome_scores,
    goals=(0, 1),
    achieved_goal=achieved_goal,
)

SPEC = SkillSpec(
    name="push",
    context=ParamSpace(("goal_x", "goal_y"), (-5.0, -5.0), (5.0, 5.0), ("units", "units")),
    control=ParamSpace(
        ("rx", "ry", "angle", "duration"), (-5.0, -5.0, 0.0, 0.0), (5.0, 5.0, 2 * math.pi, 2.0),
        ("units", "units", "rad", "s"),
    ),
    description="push a round object to a goal seen from above; g = 2 - |x - goal|",
    deterministic=True,
    outcome=OUTCOME,
)


@dataclass(frozen=True)
class PushConfig:
    """Simulation settings of a push trial (the reference's; lengths in world units)."""

    object_radius: float = 1.0
    object_density: float = 0.1
    #: Friction joint to the table: max force and max torque.
    friction_force: float = 5.0
    friction_torque: float = 2.0
    #: Pusher: ``depth`` along the push, ``width`` across it.
    pusher_depth: float = 0.6
    pusher_width: float = 2.0
    pusher_density: float = 1.0
    #: Tracked pusher speed (units/s) and the coast after the push (s).
    speed: float = 10.0
    coast_time: float = 1.0


def score(distance: float) -> float:
    return 2.0 - distance


def pusher_distance(controls: np.ndarray, config: PushConfig) -> np.ndarray:
    """Distance from the object's centre (the origin) to the pusher rectangle at its start,
    for controls ``(n, 4)``; returns ``(n,)`` (0 when the centre is inside it)."""
    rx, ry, angle = controls[:, 0], controls[:, 1], controls[:, 2]
    c, s = np.cos(angle), np.sin(angle)
    # The origin in the pusher's frame (x along the push).
    lx, ly = -(c * rx + s * ry), -(-s * rx + c * ry)
    dx = np.maximum(np.abs(lx) - config.pusher_depth / 2, 0.0)
    dy = np.maximum(np.abs(ly) - config.pusher_width / 2, 0.0)
    return np.hypot(dx, dy)


def valid_mask(context: np.ndarray, controls: np.ndarray, config: PushConfig) -> np.ndarray:
    """Whether the pusher starts clear of the object, for a batch ``(n, 4)``: ``(n,)``."""
    controls = np.asarray(controls, dtype=float).reshape(-1, 4)
    return pusher_distance(controls, config) > config.object_radius + 0.01


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
        return TrialResult(SPEC.invalid_score, False, {"reason": "pusher starts in the object"})
    rx, ry, angle, duration = (float(v) for v in control)
    kitchen = new_kitchen(observer, furniture=False, config=PhysicsConfig(gravity=(0.0, 0.0)))
    world = kitchen.world
    ground = world.CreateStaticBody(position=(0.0, 0.0))
    thing = world.CreateDynamicBody(position=(0.0, 0.0))
    thing.CreateCircleFixture(radius=config.object_radius, density=config.object_density,
                              friction=0.5)
    thing.userData = {"name": "object", "color": (200, 80, 60)}
    world.CreateFrictionJoint(bodyA=ground, bodyB=thing, localAnchorA=(0.0, 0.0),
                              localAnchorB=(0.0, 0.0), maxForce=config.friction_force,
                              maxTorque=config.friction_torque, collideConnected=False)
    goal = world.CreateStaticBody(position=(float(context[0]), float(context[1])))
    goal.CreateCircleFixture(radius=0.15, isSensor=True)
    goal.userData = {"name": "goal", "color": (40, 170, 60)}
    pusher = world.CreateDynamicBody(position=(rx, ry), angle=angle, fixedRotation=True)
    pusher.CreatePolygonFixture(box=(config.pusher_depth / 2, config.pusher_width / 2),
                                density=config.pusher_density, friction=0.5)
    pusher.userData = {"name": "gripper", "color": (230, 190, 40)}
    pusher.bullet = True  # 0.1 units per step against a 0.6 thick box: no tunnelling

    desired = b2.vec2(0.0, 0.0)

    def track(dt: float) -> None:
        # Force tracking: the force that reaches the desired velocity in one step.
        pusher.ApplyForceToCenter(pusher.mass * (desired - pusher.linearVelocity) / dt, True)

    kitchen.add_hook(track)
    desired = b2.vec2(config.speed * math.cos(angle), config.speed * math.sin(angle))
    kitchen.step(round(duration / kitchen.config.dt))
    desired = b2.vec2(0.0, 0.0)
    kitchen.step(round(config.coast_time / kitchen.config.dt))
    final = np.array(tuple(thing.position))
    distance = float(np.linalg.norm(final - np.asarray(context, dtype=float)))
    info = {
        "distance": distance,
        "final_x": float(final[0]),
        "final_y": float(final[1]),
        "final_speed": float(thing.linearVelocity.length),
        "sim_time_s": round(kitchen.time, 4),
    }
    return TrialResult(score(distance), True, info, outcome=(float(final[0]), float(final[1])))
