"""Cartesian tool-path following (the ``follow-obj-path`` stream's robot side).

Given a held tool's world poses along a path and the grasp (tool pose in the gripper
frame), find arm configurations that make the tool follow the path: the poses are first
densified, the first is solved by IK with random restarts, and each later one by IK seeded
from the previous configuration (joint-space continuity). A step is accepted only when FK
verifies it, no joint moves more than ``max_joint_step``, the straight joint segment from
the previous configuration passes the validity check densely, and — when the tool carries
contents — the tool's |roll| and |pitch| stay within the tilt limit (checked on the tool pose
reached by FK, not on the requested one).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ltamp_cli.backends.pybullet.robot.arm import PandaArm
from ltamp_cli.backends.pybullet.robot.collision import CARRY_TILT_LIMIT, within_tilt
from ltamp_cli.backends.pybullet.robot.ik import IKConfig, solve_ik, verified_ik_step
from ltamp_cli.backends.pybullet.robot.pose import Pose, interpolate_poses, rotation_distance
from ltamp_cli.motion.interpolation import interpolate_configurations

ValidityFn = Callable[[np.ndarray], bool]


@dataclass(frozen=True)
class CartesianConfig:
    """Settings of :func:`follow_tool_path`.

    ``max_translation`` (m) and ``max_rotation`` (rad): largest step between consecutive
    tool poses after densification. ``max_joint_step`` (rad): largest per-joint change
    between consecutive configurations. ``check_resolution`` (rad): spacing of validity
    checks between consecutive configurations. ``step_retries``: extra IK solves from
    slightly perturbed seeds when a step fails; ``path_restarts``: new first configurations
    tried when no start configuration is given.
    """

    max_translation: float = 0.01
    max_rotation: float = np.pi / 32
    max_joint_step: float = 0.2
    check_resolution: float = 0.05
    step_retries: int = 3
    path_restarts: int = 5
    seed_perturbation: float = 0.05
    ik: IKConfig = field(default_factory=IKConfig)

    def __post_init__(self) -> None:
        if min(self.max_translation, self.max_rotation, self.max_joint_step) <= 0:
            raise ValueError("step limits must be positive")
        if self.check_resolution <= 0 or self.seed_perturbation < 0:
            raise ValueError("check_resolution must be positive, seed_perturbation >= 0")
        if self.step_retries < 0 or self.path_restarts < 1:
            raise ValueError("step_retries must be >= 0 and path_restarts >= 1")


@dataclass(frozen=True)
class CartesianPath:
    """Outcome. ``configurations``: shape ``(n, 7)`` radians, one per densified tool pose.

    ``status`` is ``"solved"`` or the reason for failure; ``failed_index`` indexes
    ``tool_poses`` (the densified path) at the furthest failing pose.
    """

    configurations: np.ndarray | None
    tool_poses: tuple[Pose, ...]
    status: str
    failed_index: int | None = None

    @property
    def success(self) -> bool:
        return self.configurations is not None


def densify_tool_path(
    poses: Sequence[Pose], max_translation: float, max_rotation: float
) -> tuple[Pose, ...]:
    """Insert interpolated poses so no step exceeds ``max_translation`` m / ``max_rotation`` rad."""
    if len(poses) == 0:
        raise ValueError("a tool path needs at least one pose")
    dense = [poses[0]]
    for start, end in itertools.pairwise(poses):
        distance = float(np.linalg.norm(end.position - start.position))
        angle = rotation_distance(start, end)
        n_steps = max(1, int(np.ceil(max(distance / max_translation, angle / max_rotation))))
        dense.extend(interpolate_poses(start, end, k / n_steps) for k in range(1, n_steps + 1))
    return tuple(dense)


def follow_tool_path(
    arm: PandaArm,
    tool_poses: Sequence[Pose],
    grasp: Pose,
    rng: np.random.Generator,
    *,
    is_valid: ValidityFn | None = None,
    carrying_contents: bool = False,
    tilt_limit: float = CARRY_TILT_LIMIT,
    start_configuration: np.ndarray | None = None,
    config: CartesianConfig | None = None,
) -> CartesianPath:
    """Arm configurations making the held tool follow ``tool_poses`` (world frame).

    ``grasp`` is the tool's pose in the grasp-target frame (:attr:`Grasp.tool_in_gripper`).
    ``is_valid`` (e.g. an :class:`ArmCollisionChecker` with the tool attached) is applied
    densely between consecutive configurations. With ``start_configuration`` the path must
    continue from it (the first pose is solved seeded from it and must be within
    ``max_joint_step``). The arm is left at its configuration from before the call.
    """
    settings = config or CartesianConfig()
    dense = densify_tool_path(tool_poses, settings.max_translation, settings.max_rotation)
    gripper_in_tool = grasp.inverse()
    targets = [pose @ gripper_in_tool for pose in dense]
    original = arm.get_configuration()
    furthest = 0
    status = "no IK solution for the first pose"
    try:
        for attempt in range(settings.path_restarts):
            if start_configuration is not None:
                if attempt > 0:
                    break
                previous = np.asarray(start_configuration, dtype=float)
                first = _step(arm, previous, targets[0], rng, settings)
            else:
                previous = None
                first = solve_ik(arm, targets[0], rng, settings.ik)
            if first is None:
                continue
            configurations, failed_at, reason = _track(
                arm,
                first,
                previous,
                targets,
                grasp,
                rng,
                settings,
                is_valid,
                carrying_contents,
                tilt_limit,
            )
            if configurations is not None:
                return CartesianPath(configurations, dense, "solved")
            if failed_at >= furthest:
                furthest, status = failed_at, reason
        return CartesianPath(None, dense, status, furthest)
    finally:
        arm.set_configuration(original)


def _track(
    arm: PandaArm,
    first: np.ndarray,
    previous: np.ndarray | None,
    targets: list[Pose],
    grasp: Pose,
    rng: np.random.Generator,
    settings: CartesianConfig,
    is_valid: ValidityFn | None,
    carrying_contents: bool,
    tilt_limit: float,
) -> tuple[np.ndarray | None, int, str]:
    configurations: list[np.ndarray] = []
    current: np.ndarray | None = first
    for index, target in enumerate(targets):
        if index > 0:
            current = _step(arm, configurations[-1], target, rng, settings)
        if current is None:
            return None, index, "IK failed or jumped"
        reference = previous if index == 0 else configurations[-1]
        if reference is not None and _largest_jump(reference, current) > settings.max_joint_step:
            return None, index, "joint jump exceeds max_joint_step"
        if carrying_contents and not within_tilt(
            arm.forward_kinematics(current) @ grasp, tilt_limit
        ):
            return None, index, "carried tool tilts beyond the limit"
        if is_valid is not None and not _segment_valid(
            reference, current, is_valid, settings.check_resolution
        ):
            return None, index, "collision"
        configurations.append(current)
    return np.stack(configurations), len(targets), "solved"


def _step(
    arm: PandaArm,
    seed: np.ndarray,
    target: Pose,
    rng: np.random.Generator,
    settings: CartesianConfig,
) -> np.ndarray | None:
    """IK seeded from ``seed`` that stays within ``max_joint_step`` of it, or ``None``."""
    for attempt in range(settings.step_retries + 1):
        start = seed
        if attempt > 0:
            noise = rng.uniform(-1.0, 1.0, size=seed.shape) * settings.seed_perturbation
            start = np.clip(seed + noise, arm.lower_limits, arm.upper_limits)
        candidate = verified_ik_step(arm, start, target, settings.ik)
        if candidate is not None and _largest_jump(seed, candidate) <= settings.max_joint_step:
            return candidate
    return None


def _largest_jump(q_from: np.ndarray, q_to: np.ndarray) -> float:
    return float(np.max(np.abs(np.asarray(q_to) - np.asarray(q_from))))


def _segment_valid(
    q_from: np.ndarray | None, q_to: np.ndarray, is_valid: ValidityFn, resolution: float
) -> bool:
    if q_from is None:
        return bool(is_valid(q_to))
    segment = interpolate_configurations(q_from, q_to, resolution)
    # The first configuration was accepted at the previous step.
    return all(is_valid(q) for q in segment[1:])
