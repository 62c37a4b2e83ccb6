"""A plan's skill actions run in the physics of that skill's trials (issue #20).

The scoop's trials moved to 50 PyBullet solver iterations (``pybullet@v1.1``) while the plan
executor kept simulating its scoop at its world's 5: the executed skill was not the one the
model was trained on. These tests spy on every step an action takes and compare the solver
iterations and contact breaking threshold the executor's client actually ran with against
the trial backend's world for that skill (``Kitchen3DBackend.world_config``) and its
physics tag (``TrialRecord.physics``).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable

import numpy as np
import pytest

from ltamp_cli.backends.pybullet.backend import Kitchen3DBackend
from ltamp_cli.backends.pybullet.executor import (
    ACTION_SKILLS,
    ActionFailed,
    ExecutionSettings,
    Kitchen3DRun,
)
from ltamp_cli.backends.pybullet.robot.arm import PANDA_HOME
from ltamp_cli.backends.pybullet.robot.pose import Pose
from ltamp_cli.backends.pybullet.tamp.scene import scene_from_world
from ltamp_cli.backends.pybullet.tamp.values import ArmPath
from ltamp_cli.backends.pybullet.world import (
    PhysicsWorld,
    WorldConfig,
    physics_tag,
    skill_world_config,
)

WORLD = {"arms": 1, "objects": {
    "sugarbowl": {"kind": "bowl", "top_diameter": 0.18, "base_diameter": 0.12, "height": 0.07,
                  "fixed": True, "at": [0.1, 0.2], "contents": {"material": "sugar", "beads": 10}},
    "cup": {"kind": "cup", "top_diameter": 0.08, "base_diameter": 0.06, "height": 0.1},
    "block": {"kind": "block", "size": [0.05, 0.05, 0.05]},
    "spoon": {"kind": "spoon", "length": 0.2},
    "stirrer": {"kind": "stirrer", "length": 0.2}},
    "regions": {"table": [[-0.3, 0.3], [-0.3, 0.3]]}}
POSES = {"cup": (-0.1, 0.25), "block": (0.2, -0.2), "spoon": (-0.15, -0.3),
         "stirrer": (0.25, 0.1)}
#: Short holds and settles: what is measured is the physics of each step, not the outcome.
SETTINGS = ExecutionSettings(settle_s=0.02, pour_hold_s=0.02)


def _home_path(kind: str, held: str | None) -> ArmPath:
    """Arm 0 staying at home (two equal configurations) as a path of ``kind``."""
    q = np.asarray(PANDA_HOME, dtype=float)
    return ArmPath(0, np.stack([q, q]), kind, held=None if held is None else (held, None))


def _act(run: Kitchen3DRun, action: str) -> None:
    """Run ``action`` once on ``run`` with a motionless path (its outcome may fail)."""
    holds = {"pour": "cup", "scoop": "spoon", "stir": "stirrer"}
    if action in holds:
        run.held[0] = (holds[action], Pose(np.array([0.0, 0.0, 0.1]), np.array([0, 0, 0, 1.0])))
        run.pinned.pop(holds[action], None)
    calls: dict[str, Callable[[], None]] = {
        "pour": lambda: run.pour(_home_path("pour", "cup")),
        "scoop": lambda: run.scoop("spoon", "sugarbowl", "sugar", _home_path("scoop", "spoon")),
        "stir": lambda: run.stir("stirrer", "cup", _home_path("stir", "stirrer")),
        "push": lambda: run.push("block", (0.2 + math.cos(0.3) * 0.1, -0.2),
                                 _home_path("push", None)),
    }
    # A motionless scoop lifts nothing, a motionless push misses its goal.
    with contextlib.suppress(ActionFailed):
        calls[action]()


@pytest.mark.parametrize("action", sorted(ACTION_SKILLS))
def test_each_skill_action_steps_in_its_trials_physics(action: str) -> None:
    run = Kitchen3DRun(scene_from_world(WORLD), POSES, 0, SETTINGS, None)
    try:
        seen: list[tuple[int, float]] = []
        step = run.world.step

        def spy(n: int = 1) -> None:
            seen.append((run.world.solver_iterations(), run.world.contact_breaking_m))
            step(n)

        run.world.step = spy  # type: ignore[method-assign]
        _act(run, action)
        assert seen, f"{action} took no step"
        trial = Kitchen3DBackend().world_config(ACTION_SKILLS[action])
        executed = {(trial.solver_iterations, trial.contact_breaking_threshold)}
        assert set(seen) == executed
        iterations, threshold = seen[0]
        tag = physics_tag(ACTION_SKILLS[action], WorldConfig(
            solver_iterations=iterations, contact_breaking_threshold=threshold))
        assert tag == Kitchen3DBackend().physics_tag(ACTION_SKILLS[action])
        # Afterwards the world runs its own settings again.
        assert run.world.solver_iterations() == run.world.config.solver_iterations
        assert run.world.contact_breaking_m == run.world.config.contact_breaking_threshold
    finally:
        run.close()


def test_the_scoop_executes_at_the_scoop_trials_50_iterations() -> None:
    """The case that diverged: the world's own 5 iterations are not the scoop trials' 50."""
    assert skill_world_config("scoop").solver_iterations == 50
    assert WorldConfig().solver_iterations != skill_world_config("scoop").solver_iterations


def test_skill_physics_sets_and_restores_the_clients_settings() -> None:
    with PhysicsWorld(WorldConfig()) as world:
        with world.skill_physics(WorldConfig(solver_iterations=17,
                                             contact_breaking_threshold=0.02)):
            assert world.solver_iterations() == 17
            assert world.contact_breaking_m == 0.02
        assert world.solver_iterations() == 5
        assert world.contact_breaking_m == WorldConfig().contact_breaking_threshold
        with pytest.raises(RuntimeError), world.skill_physics(WorldConfig(solver_iterations=9)):
            raise RuntimeError("an action failed")
        assert world.solver_iterations() == 5
        with pytest.raises(ValueError, match="time step"), world.skill_physics(
                WorldConfig(time_step=0.01)):
            pass


def test_an_action_of_no_skill_has_no_skill_physics() -> None:
    run = Kitchen3DRun(scene_from_world(WORLD), POSES, 0, SETTINGS, None)
    try:
        with pytest.raises(KeyError):
            run.skill_physics("dump")
    finally:
        run.close()
