"""Which robots can run trials: the limits of ``--robot`` for the CLI and the Python API."""

from __future__ import annotations

from ltamp_cli.errors import InputError

#: ``robot`` values, and the (backend, skills) that take a robot.
ROBOT_CHOICES = ("none", "panda")
ROBOT_BACKEND = "pybullet"
ROBOT_SKILLS = ("pour", "scoop", "push", "stir")


def check_robot(robot: str, backend: str, skill: str) -> None:
    """``robot`` must name a known robot, and a robot needs a PyBullet Kitchen3D skill.

    The words are those of ``ltamp collect/train --robot``;
    :func:`~ltamp_cli.trials.collect.collect` checks its job with it too.
    """
    if robot not in ROBOT_CHOICES:
        raise InputError(f"--robot: expected one of {', '.join(ROBOT_CHOICES)}, got {robot!r}")
    if robot != "none" and (backend != ROBOT_BACKEND or skill not in ROBOT_SKILLS):
        raise InputError(f"--robot {robot}: only --backend {ROBOT_BACKEND} with skill "
                         f"{', '.join(ROBOT_SKILLS)} runs trials with a robot, not "
                         f"{backend}/{skill}")
