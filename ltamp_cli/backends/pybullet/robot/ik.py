"""Inverse kinematics of the Panda's grasp target with random restarts, verified by FK.

pybullet's damped-least-squares IK (``calculateInverseKinematics``, no null-space terms:
the null-space variant was seen to miss by 0.13 m) is seeded from the arm's current joint
state; it ignores joint limits, so every answer is wrapped by ±2π into the limits when that
is possible, rejected otherwise, and always checked by forward kinematics.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pybullet

from ltamp_cli.backends.pybullet.robot.arm import PANDA_EE_LINK, PandaArm
from ltamp_cli.backends.pybullet.robot.pose import Pose, rotation_distance


@dataclass(frozen=True)
class IKConfig:
    """``restarts``: random seeds tried after the given one; ``refinements``: extra solves
    from a clipped or unconverged answer. Tolerances: metres and radians."""

    restarts: int = 20
    max_iterations: int = 200
    residual_threshold: float = 1e-5
    position_tolerance: float = 1e-3
    orientation_tolerance: float = 1e-2
    refinements: int = 3

    def __post_init__(self) -> None:
        if self.restarts < 0 or self.refinements < 0 or self.max_iterations <= 0:
            raise ValueError("restarts and refinements must be >= 0, max_iterations > 0")
        if self.position_tolerance <= 0 or self.orientation_tolerance <= 0:
            raise ValueError("tolerances must be positive")


def pose_error(arm: PandaArm, q: np.ndarray, target: Pose) -> tuple[float, float]:
    """``(position error m, orientation error rad)`` of FK(``q``) against ``target``."""
    reached = arm.forward_kinematics(q)
    return (
        float(np.linalg.norm(reached.position - target.position)),
        rotation_distance(reached, target),
    )


def wrap_into_limits(arm: PandaArm, q: np.ndarray) -> np.ndarray | None:
    """``q`` with joints shifted by multiples of 2π into the limits, or ``None``."""
    wrapped = np.asarray(q, dtype=float).copy()
    for i in range(wrapped.shape[0]):
        low, high = arm.lower_limits[i], arm.upper_limits[i]
        if low <= wrapped[i] <= high:
            continue
        shifted = wrapped[i] - 2 * np.pi * np.floor((wrapped[i] - low) / (2 * np.pi))
        if not low <= shifted <= high:
            return None
        wrapped[i] = shifted
    return wrapped


def _raw_ik(arm: PandaArm, seed: np.ndarray, target: Pose, config: IKConfig) -> np.ndarray:
    arm.set_configuration(seed)
    position, quaternion = target.as_tuples()
    solution = pybullet.calculateInverseKinematics(
        arm.body_id,
        PANDA_EE_LINK,
        targetPosition=position,
        targetOrientation=quaternion,
        maxNumIterations=config.max_iterations,
        residualThreshold=config.residual_threshold,
        physicsClientId=arm.client_id,
    )
    # The answer covers every movable joint (7 arm + 2 fingers); the arm joints come first.
    return np.asarray(solution[: arm.dof], dtype=float)


def solve_ik(
    arm: PandaArm,
    target: Pose,
    rng: np.random.Generator,
    config: IKConfig | None = None,
    seed_configuration: np.ndarray | None = None,
    is_valid: Callable[[np.ndarray], bool] | None = None,
) -> np.ndarray | None:
    """A configuration (shape ``(7,)``) putting the grasp target at ``target``, or ``None``.

    Tries ``seed_configuration`` (default: the current configuration) first, then
    ``config.restarts`` uniform random seeds from ``rng``. A solution is returned only when
    it is inside the joint limits, FK reaches ``target`` within the tolerances, and
    ``is_valid`` (e.g. a collision check) accepts it. The arm is left at its configuration
    from before the call.
    """
    settings = config or IKConfig()
    original = arm.get_configuration()
    first_seed = original if seed_configuration is None else np.asarray(seed_configuration)
    try:
        for attempt in range(settings.restarts + 1):
            seed = first_seed if attempt == 0 else arm.sample_configuration(rng)
            candidate = verified_ik_step(arm, seed, target, settings)
            if candidate is None:
                continue
            if is_valid is not None and not is_valid(candidate):
                continue
            return candidate
        return None
    finally:
        arm.set_configuration(original)


def verified_ik_step(
    arm: PandaArm, seed: np.ndarray, target: Pose, config: IKConfig
) -> np.ndarray | None:
    """One IK solve from ``seed``: the FK-verified, limit-respecting answer or ``None``.

    An answer outside the limits is clipped into them and an unconverged one is used as
    the next seed, for ``config.refinements`` extra solves: DLS ignores limits, and
    re-solving from the projection recovers most such cases. Leaves the arm at the last
    candidate configuration.
    """
    current = np.asarray(seed, dtype=float)
    for _ in range(config.refinements + 1):
        raw = _raw_ik(arm, current, target, config)
        candidate = wrap_into_limits(arm, raw)
        if candidate is None:
            current = np.clip(raw, arm.lower_limits, arm.upper_limits)
            continue
        position_error, orientation_error = pose_error(arm, candidate, target)
        if (
            position_error <= config.position_tolerance
            and orientation_error <= config.orientation_tolerance
        ):
            return candidate
        current = candidate
    return None
