"""Push: the closed gripper's fingertips slide a block along a straight line on the table.

Frames: the block's base centre starts at the world origin (table top, ``z = 0``); the target
is ``(goal_x, 0)``, so the push runs along ``+x``. The fingertips (:data:`PAD_SIZE_M`, a
box standing in for the closed Panda fingers) start :data:`APPROACH_GAP_M` behind the block's
``-x`` face and move kinematically along ``+x`` at constant speed, then stop and stay.

Context (4): block side (m, a cube), block mass (kg), block lateral friction coefficient
(Bullet multiplies it with the table's 0.6), and the goal ``goal_x`` (m): a *pure goal*
(issue #20/#21). The pad's path depends on the block's side and the control only, so the
physics never sees the goal; the skill declares an :class:`~ltamp_cli.backends.protocol.
OutcomeSpec` (the block's final ``x``, ``y`` and rotation, the score as a function of them
and the goal, achieved goal = final ``x``) and learners relabel each trial for other goals
(:mod:`ltamp_cli.learning.outcomes`). Before, the context's ``distance`` set where the pad
stopped (``stop_offset`` was relative to it), so a learned push was told the answer.

Control (4):

* ``contact_height`` ∈ [0.05, 0.95]: the pad's centre height as a fraction of the block's
  height (high contacts tip the block over);
* ``speed`` ∈ [0.02, 0.4] m/s: pad speed (a fast push lets the block slide on after the
  pad stops);
* ``lateral_offset`` ∈ [-0.5, 0.5]: the pad's ``y`` as a fraction of the block's side
  (off-centre pushes turn the block and deflect it);
* ``travel`` ∈ [0, 0.3] m: how far the pad advances past the block's resting back face,
  i.e. where the block's centre would stop if it stopped with the pad (it may slide on, lag
  or turn). The range is the old parameterisation's reach (distance + stop offset, 0-0.3 m).

A control whose pad would start below the table (``contact_height × side`` less than half
the pad's height plus :data:`PAD_CLEARANCE_M`) is invalid and not simulated.

Score (the reference's criterion: success iff the final position error is at most 2.5 cm and
the rotation error at most 0.1 rad): ``g = min(1 − e / PUSH_TOLERANCE_M,
1 − r / PUSH_ROTATION_TOLERANCE_RAD)`` clipped to ``[-1, 1]``, with ``e`` the distance (m) of
the block's final base centre from the target and ``r`` the angle (rad) of its final
rotation from its start orientation, the target's (a toppled block has ``r ≥ π/2``).
``g > 0`` exactly when ``e < 2.5 cm`` and ``r < 0.1 rad``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ltamp_cli.backends.kitchenware_geometry import KitchenwareGeometry, block_geometry, box_piece
from ltamp_cli.backends.protocol import OutcomeSpec, ParamSpace, SkillSpec, TrialResult
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial
from ltamp_cli.backends.pybullet.paths import PosePath, timed_poses
from ltamp_cli.backends.skills3d.common import (
    PathCheck,
    SkillTrial,
    rejection,
    truncated_normal,
)
from ltamp_cli.backends.skills3d.physics import StepCallback, TrialPhysics

#: Full extents (m) of the fingertip pad: x (push direction), y, z.
PAD_SIZE_M = (0.016, 0.02, 0.03)
#: The pad's lowest point must stay this far (m) above the table.
PAD_CLEARANCE_M = 0.002
#: The pad starts this far (m) behind the block's face.
APPROACH_GAP_M = 0.02
#: Final position error (m) at which the score crosses zero (reference: 2.5 cm).
PUSH_TOLERANCE_M = 0.025
#: Final rotation error (rad) at which the score crosses zero (reference: 0.1 rad).
PUSH_ROTATION_TOLERANCE_RAD = 0.1
#: A block tilted by more than this (rad) has toppled (reported in ``info``).
TOPPLE_RAD = math.radians(30.0)
#: Fingertips are reset every step (kinematic); a heavy pad barely yields within a step.
PAD_MASS_KG = 2.0
#: The fingertip pad's material (an engine with true kinematic tools ignores the mass).
PAD_MATERIAL = BodyMaterial(mass=PAD_MASS_KG, lateral_friction=0.5, restitution=0.0,
                            rgba=(0.2, 0.2, 0.2, 1.0))
IDENTITY_QUAT = np.array([0.0, 0.0, 0.0, 1.0])

PUSH_CONTEXT = ParamSpace(
    names=("block_size", "block_mass", "block_friction", "goal_x"),
    lows=(0.04, 0.1, 0.3, 0.05),
    highs=(0.08, 0.5, 0.8, 0.25),
    units=("m", "kg", "", "m"),
)
PUSH_CONTROL = ParamSpace(
    names=("contact_height", "speed", "lateral_offset", "travel"),
    lows=(0.05, 0.02, -0.5, 0.0),
    highs=(0.95, 0.4, 0.5, 0.3),
    units=("× block side", "m/s", "× block side", "m"),
)
#: The outcome: the block's final base centre ``x``, ``y`` (m) and rotation (rad, [0, π]).
PUSH_OUTCOME_SPACE = ParamSpace(
    names=("final_x", "final_y", "rotation"),
    lows=(-0.1, -0.3, 0.0),
    highs=(0.6, 0.3, math.pi),
    units=("m", "m", "rad"),
)
#: Index of the goal in the context.
GOAL_INDEX = 3


def push_outcome_scores(contexts: np.ndarray, controls: np.ndarray,
                        outcomes: np.ndarray) -> np.ndarray:
    """Scores ``(n,)`` of outcomes ``(n, 3)`` for goals ``contexts[:, 3]`` (m); the same
    criterion as :func:`push_score` (vectorised, the control is not needed)."""
    outcomes = np.asarray(outcomes, dtype=float).reshape(-1, 3)
    goals = np.asarray(contexts, dtype=float).reshape(len(outcomes), -1)[:, GOAL_INDEX]
    error = np.hypot(outcomes[:, 0] - goals, outcomes[:, 1])
    margin = np.minimum(1.0 - error / PUSH_TOLERANCE_M,
                        1.0 - outcomes[:, 2] / PUSH_ROTATION_TOLERANCE_RAD)
    return np.clip(margin, -1.0, 1.0)


def push_achieved_goal(outcomes: np.ndarray) -> np.ndarray:
    """The goal ``(n, 1)`` each outcome ``(n, 3)`` reaches best: its final ``x``."""
    return np.asarray(outcomes, dtype=float).reshape(-1, 3)[:, :1]


PUSH_SPEC = SkillSpec(
    name="push",
    context=PUSH_CONTEXT,
    control=PUSH_CONTROL,
    description="push a block along a line to a goal with the fingertips (Kitchen3D)",
    outcome=OutcomeSpec(space=PUSH_OUTCOME_SPACE, score=push_outcome_scores,
                        goals=(GOAL_INDEX,), achieved_goal=push_achieved_goal),
)


@dataclass(frozen=True)
class PushSettings:
    """Timing: settle before and after the push (s); the pad's turn rate is irrelevant."""

    settle_s: float = 0.2
    after_s: float = 0.6


@dataclass(frozen=True)
class PushContext:
    """One push context (metres, kilograms, friction coefficient; the goal in metres)."""

    size: float
    mass: float
    friction: float
    goal_x: float

    @staticmethod
    def from_array(context: np.ndarray) -> PushContext:
        c = np.asarray(context, dtype=float).reshape(-1)
        if c.shape != (4,):
            raise ValueError(f"a push context has 4 values, got {c.shape[0]}")
        return PushContext(float(c[0]), float(c[1]), float(c[2]), float(c[3]))

    def to_array(self) -> np.ndarray:
        return np.array([self.size, self.mass, self.friction, self.goal_x])


def sample_push_context(rng: np.random.Generator) -> np.ndarray:
    """Uniform in the context box, shape ``(4,)``."""
    return PUSH_CONTEXT.sample_uniform(rng, 1)[0]


def pad_geometry() -> KitchenwareGeometry:
    """The fingertip pad: a box centred on its frame's origin."""
    half = np.asarray(PAD_SIZE_M) / 2.0
    return KitchenwareGeometry("pusher", (box_piece(np.zeros(3), half, np.eye(3)),))


def push_path(context: PushContext, control: np.ndarray) -> PosePath:
    """The pad's centre at the start and the end of the push, shape ``(2, ·)``: from
    :data:`APPROACH_GAP_M` behind the block's back face to ``travel`` past it (the goal
    plays no part)."""
    height, _, lateral, travel = np.asarray(control, dtype=float).reshape(4)
    half_pad = PAD_SIZE_M[0] / 2.0
    z = height * context.size
    y = lateral * context.size
    start_x = -context.size / 2.0 - half_pad - APPROACH_GAP_M
    end_x = travel - context.size / 2.0 - half_pad
    positions = np.array([[start_x, y, z], [end_x, y, z]])
    return PosePath(positions, np.stack([IDENTITY_QUAT, IDENTITY_QUAT]))


def push_is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """The pad stays above the table: bool ``(n,)`` for ``controls (n, 4)``."""
    scene = PushContext.from_array(context)
    batch = np.asarray(controls, dtype=float).reshape(-1, 4)
    return batch[:, 0] * scene.size - PAD_SIZE_M[2] / 2.0 >= PAD_CLEARANCE_M


def check_push(context: np.ndarray, control: np.ndarray) -> PathCheck:
    """The pre-check of one control, with the reason when it fails."""
    if push_is_valid(context, control)[0]:
        return PathCheck(True)
    return PathCheck(False, 0, "fingertip pad below the table")


def prepare_push(context: np.ndarray, control: np.ndarray, check: bool
                 ) -> SkillTrial[PushContext]:
    """Context ``(4,)`` and control ``(4,)`` parsed, the pad's path and geometry, and (with
    ``check``) the pre-check's rejection: the engine-independent start of a push trial."""
    scene = PushContext.from_array(context)
    control = np.asarray(control, dtype=float).reshape(4)
    rejected = rejection(PUSH_SPEC, check_push(context, control)) if check else None
    return SkillTrial(scene, control, push_path(scene, control), pad_geometry(), rejected)


def push_score(error_m: float, rotation_rad: float) -> float:
    """``clip(min(1 − error / PUSH_TOLERANCE_M, 1 − rotation /
    PUSH_ROTATION_TOLERANCE_RAD), −1, 1)``: positive iff both errors are within tolerance."""
    margin = min(1.0 - error_m / PUSH_TOLERANCE_M,
                 1.0 - rotation_rad / PUSH_ROTATION_TOLERANCE_RAD)
    return float(np.clip(margin, -1.0, 1.0))


def rotation_angle(quaternion: np.ndarray) -> float:
    """Angle (rad, in ``[0, π]``) of the rotation ``quaternion`` ``(4,)`` xyzw from the
    identity, the block's start and target orientation."""
    q = np.asarray(quaternion, dtype=float)
    w = abs(float(q[3])) / float(np.linalg.norm(q))
    return float(2.0 * math.acos(min(1.0, w)))


def tilt_of(quaternion: np.ndarray) -> float:
    """Angle (rad) between a body's ``z`` axis and the vertical."""
    x, y, _, _ = (float(v) for v in quaternion)
    # z component of R @ e_z is 1 - 2(x² + y²).
    return float(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y)))))


def block_material(scene: PushContext, rng: np.random.Generator) -> BodyMaterial:
    """The block's material: mass and friction from the context, restitution drawn."""
    return BodyMaterial(
        mass=scene.mass,
        lateral_friction=scene.friction,
        restitution=truncated_normal(rng, 0.1, 0.05, 0.0, 0.2),
        rgba=(0.3, 0.6, 0.3, 1.0),
    )


def push_outcome(scene: PushContext, position: np.ndarray, quaternion: np.ndarray,
                 steps: int, dt: float) -> TrialResult:
    """Score, outcome ``(final_x, final_y, rotation)`` and ``info`` from the block's final
    pose (shared with the SAPIEN push)."""
    error = float(np.hypot(position[0] - scene.goal_x, position[1]))
    tilt = tilt_of(quaternion)
    rotation = rotation_angle(quaternion)
    info = {
        "final_xy": [float(position[0]), float(position[1])],
        "error_m": error,
        "rotation_rad": rotation,
        "tilt_rad": tilt,
        "toppled": tilt > TOPPLE_RAD,
        "sim_steps": steps,
        "sim_time_s": steps * dt,
    }
    return TrialResult(push_score(error, rotation), True, info,
                       outcome=(float(position[0]), float(position[1]), rotation))


def run_push(
    physics: TrialPhysics,
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    settings: PushSettings | None = None,
    on_step: StepCallback | None = None,
    check: bool = True,
) -> TrialResult:
    """Simulate one push with ``physics`` (reset first); deterministic given ``seed``. The
    block is free; the fingertip pad is a tool."""
    settings = settings or PushSettings()
    trial = prepare_push(context, control, check)
    if trial.rejected is not None:
        return trial.rejected
    scene, path = trial.scene, trial.path
    rng = np.random.default_rng(seed)
    physics.reset()
    size = scene.size
    block = physics.add_body(block_geometry((size, size, size)), block_material(scene, rng),
                             "free")
    pad = physics.add_body(trial.tool, PAD_MATERIAL, "tool", path.positions[0],
                           path.quaternions[0])
    dt = physics.time_step
    steps = physics.hold(pad, path.positions[0], path.quaternions[0],
                         physics.steps_for(settings.settle_s), on_step)
    timed = timed_poses(path, speed=float(trial.control[1]), angular_speed=1.0, dt=dt)
    steps += physics.follow(pad, timed, on_step, steps)
    steps += physics.hold(pad, path.positions[-1], path.quaternions[-1],
                          physics.steps_for(settings.after_s), on_step, steps)
    position, quaternion = block.pose()
    return push_outcome(scene, position, quaternion, steps, dt)


__all__ = [
    "GOAL_INDEX",
    "PUSH_CONTEXT",
    "PUSH_CONTROL",
    "PUSH_OUTCOME_SPACE",
    "PUSH_ROTATION_TOLERANCE_RAD",
    "PUSH_SPEC",
    "PUSH_TOLERANCE_M",
    "PushContext",
    "PushSettings",
    "check_push",
    "pad_geometry",
    "prepare_push",
    "push_achieved_goal",
    "push_is_valid",
    "push_outcome",
    "push_outcome_scores",
    "push_path",
    "push_score",
    "rotation_angle",
    "run_push",
    "sample_push_context",
]
