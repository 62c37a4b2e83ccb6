"""The Kitchen3D :class:`~ltamp_cli.backends.protocol.SkillBackend` (PyBullet).

One backend owns one :class:`~.world.PhysicsWorld` (its own headless client) per world
setting its skills use: each skill's world takes its contact breaking threshold from
:data:`~.world.SKILL_CONTACT_BREAKING_M` (push 2 cm, the bead skills 4 mm), so the push and
the bead skills run in two worlds. A world is created on first use and reset, not recreated,
for every trial of a skill with its setting.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import MappingProxyType

import numpy as np

from ltamp_cli.backends.protocol import SkillSpec, TrialResult, as_batch
from ltamp_cli.backends.pybullet.guard import bullet_guard
from ltamp_cli.backends.pybullet.paths import PosePath
from ltamp_cli.backends.pybullet.render import Camera, FrameRecorder
from ltamp_cli.backends.pybullet.skills.physics import BulletTrialPhysics
from ltamp_cli.backends.pybullet.skills.robot import (
    ROBOT_SETUP_VERSIONS,
    ROBOTS,
    RobotFailure,
    RobotSettings,
    RobotTrialPhysics,
)
from ltamp_cli.backends.pybullet.world import (
    PhysicsWorld,
    WorldConfig,
    physics_tag,
    skill_world_config,
)
from ltamp_cli.backends.sanity import run_guarded
from ltamp_cli.backends.skills3d.common import PathCheck
from ltamp_cli.backends.skills3d.physics import StepCallback
from ltamp_cli.backends.skills3d.pour import (
    POUR_SPEC,
    PourSettings,
    check_pour,
    pour_is_valid,
    prepare_pour,
    sample_pour_context,
)
from ltamp_cli.backends.skills3d.push import (
    PUSH_SPEC,
    PushSettings,
    check_push,
    prepare_push,
    push_is_valid,
    sample_push_context,
)
from ltamp_cli.backends.skills3d.scoop import (
    SCOOP_SPEC,
    ScoopSettings,
    check_scoop,
    prepare_scoop,
    sample_scoop_context,
    scoop_is_valid,
)
from ltamp_cli.backends.skills3d.stir import (
    STIR_SPEC,
    StirSettings,
    check_stir,
    prepare_stir,
    sample_stir_context,
    stir_is_valid,
)
from ltamp_cli.backends.skills3d.trials import (
    SkillSettings,
    run_skill_trial,
    score_from_fraction,
)

_SPECS: Mapping[str, SkillSpec] = MappingProxyType(
    {"pour": POUR_SPEC, "scoop": SCOOP_SPEC, "push": PUSH_SPEC, "stir": STIR_SPEC}
)
#: The engine-independent parts of each skill: pre-check of one control, batch validity,
#: context distribution (shared with the SAPIEN backend).
_CHECKS: Mapping[str, Callable[[np.ndarray, np.ndarray], PathCheck]] = MappingProxyType(
    {"pour": check_pour, "scoop": check_scoop, "push": check_push, "stir": check_stir}
)
_VALIDITY: Mapping[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = MappingProxyType(
    {"pour": pour_is_valid, "scoop": scoop_is_valid, "push": push_is_valid,
     "stir": stir_is_valid}
)
_CONTEXTS: Mapping[str, Callable[[np.random.Generator], np.ndarray]] = MappingProxyType(
    {"pour": sample_pour_context, "scoop": sample_scoop_context, "push": sample_push_context,
     "stir": sample_stir_context}
)
KNOWN_SKILLS = ", ".join(_SPECS)
#: Skills whose trials can run with the Panda in the loop (``robot="panda"``).
ROBOT_SKILLS = ("pour", "scoop", "push", "stir")
#: The untimed tool path of a skill's trial (what the Panda plans before it grasps).
_PREVIEWS: Mapping[str, Callable[[np.ndarray, np.ndarray], PosePath]] = MappingProxyType({
    "pour": lambda context, control: prepare_pour(context, control, check=False).path,
    "scoop": lambda context, control: prepare_scoop(context, control, check=False).path,
    "push": lambda context, control: prepare_push(context, control, check=False).path,
    "stir": lambda context, control: prepare_stir(context, control, check=False).path,
})
#: Where the Panda's base stands around the tool, per skill (radians about z from +x, tried
#: in turn) and from which point: a pour tilts about y, so its base is at -y or +y of the
#: cup; the scoop's spoon moves along y with its handle up towards +y, so its base is at +y
#: first; the push runs along +x, so its base is at -y or +y of the push's middle; the
#: stirrer circles in a cup at the origin.
SKILL_BEARINGS: Mapping[str, tuple[tuple[float, ...], str]] = MappingProxyType({
    "pour": ((-np.pi / 2, np.pi / 2), "start"),
    "scoop": ((np.pi / 2, 0.0, np.pi), "start"),
    "push": ((-np.pi / 2, np.pi / 2), "middle"),
    "stir": ((-np.pi / 2, np.pi / 2), "start"),
})


def backend_tag(robot: str) -> str:
    """The backend name trial records carry: ``pybullet`` for free-floating tools,
    ``pybullet+panda`` with the Panda in the loop (so the two kinds of labels never mix)."""
    return "pybullet" if robot == "none" else f"pybullet+{robot}"


def precheck_trial(spec: SkillSpec, context: np.ndarray, control: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, TrialResult | None]:
    """Shapes checked and the geometric pre-check run *before* any world is touched: invalid
    controls never create or step one. Returns the flattened inputs and the result of a
    rejected trial (``None`` when it may be simulated). Shared by the 3D backends."""
    context = np.asarray(context, dtype=float).reshape(-1)
    control = np.asarray(control, dtype=float).reshape(-1)
    if context.shape != (spec.context.dim,) or control.shape != (spec.control.dim,):
        raise ValueError(
            f"{spec.name}: expected context of {spec.context.dim} and control of "
            f"{spec.control.dim} values, got {context.size} and {control.size}"
        )
    verdict = _CHECKS[spec.name](context, control)
    if not verdict.valid:
        return context, control, TrialResult(spec.invalid_score, False,
                                              {"reason": verdict.reason})
    return context, control, None


class Kitchen3DBackend:
    """PyBullet Kitchen3D: skills ``pour``, ``scoop`` (learned in the paper), ``push`` and
    ``stir`` (engineered, but trials and scores work the same way).

    Options: ``gui`` (open a PyBullet window instead of ``DIRECT``), ``solver_iterations``,
    per-skill timing via ``pour_settings``/``scoop_settings``/``push_settings``/
    ``stir_settings``, and ``robot``: ``"none"`` (the tool moves free-floating along the
    skill's path) or ``"panda"`` (every skill: a Panda grasps the cup, the spoon, the
    fingertip pad or the stirrer and follows the path by IK and joint position control at
    the skill's timing; reach, arm collisions and slip fail the trial, see
    :mod:`.skills.robot`; ``robot_settings`` tunes it). The robot is part of the trial
    records' identity: :attr:`name` is ``pybullet+panda`` then. ``contact_breaking_m``
    replaces some skills' contact breaking thresholds (metres, e.g. ``{"push": 0.004}``; a
    what-if for benchmarks, the shipped ones are :data:`~.world.SKILL_CONTACT_BREAKING_M`).
    """

    name = "pybullet"

    def __init__(
        self,
        gui: bool = False,
        solver_iterations: int | None = None,
        pour_settings: PourSettings | None = None,
        scoop_settings: ScoopSettings | None = None,
        push_settings: PushSettings | None = None,
        stir_settings: StirSettings | None = None,
        robot: str = "none",
        robot_settings: RobotSettings | None = None,
        contact_breaking_m: Mapping[str, float] | None = None,
    ) -> None:
        if robot not in ROBOTS:
            raise ValueError(f"robot must be one of {', '.join(ROBOTS)}, got {robot!r}")
        self.robot = robot
        self.robot_settings = robot_settings or RobotSettings()
        self.name = backend_tag(robot)
        #: The settings every skill's world shares (each skill's world then takes its own
        #: contact breaking threshold, :meth:`world_config`).
        self.config = WorldConfig(gui=bool(gui))
        #: Solver iterations of every skill's world (a what-if); ``None``: each skill's own
        #: (:data:`~.world.SKILL_SOLVER_ITERATIONS`).
        self.solver_iterations = None if solver_iterations is None else int(solver_iterations)
        unknown = set(contact_breaking_m or {}) - set(_SPECS)
        if unknown:
            raise ValueError(f"contact_breaking_m: unknown skills {sorted(unknown)} "
                             f"(known: {KNOWN_SKILLS})")
        self.contact_breaking_m: Mapping[str, float] = MappingProxyType(
            {skill: float(m) for skill, m in (contact_breaking_m or {}).items()})
        for skill in (_SPECS if self.solver_iterations is not None else self.contact_breaking_m):
            self.world_config(skill)  # a bad setting fails here, not in the first trial
        self.pour_settings = pour_settings or PourSettings()
        self.scoop_settings = scoop_settings or ScoopSettings()
        self.push_settings = push_settings or PushSettings()
        self.stir_settings = stir_settings or StirSettings()
        self._worlds: dict[WorldConfig, PhysicsWorld] = {}

    def trial_setup(self, skill: str) -> str | None:
        """The robot setup of ``skill``'s trials, which their records carry: ``None`` for
        free-floating tools, else ``"<robot>-r<version>"`` (:data:`ROBOT_SETUP_VERSIONS`:
        ``"panda-r3"`` for the pour), so trials of two setups are never mixed."""
        self._spec(skill)
        if self.robot == "none":
            return None
        return f"{self.robot}-r{ROBOT_SETUP_VERSIONS[skill]}"

    def world_config(self, skill: str) -> WorldConfig:
        """The world settings of ``skill``'s trials: :attr:`config` with the skill's
        contact breaking threshold and solver iterations (or this backend's what-ifs)."""
        self._spec(skill)
        return skill_world_config(skill, self.config, self.contact_breaking_m,
                                  self.solver_iterations)

    def physics_tag(self, skill: str) -> str:
        """The physics ``skill``'s trials on this backend carry (``TrialRecord.physics``):
        ``pybullet@v<physics_version(skill)>``, with a suffix for a what-if setting
        (:func:`~.world.physics_tag`)."""
        return physics_tag(skill, self.world_config(skill))

    def world_for(self, skill: str) -> PhysicsWorld:
        """The physics world of ``skill``'s trials (connected lazily, reused across trials;
        skills with equal settings share it). Worlds of different thresholds cannot leak
        into each other: :meth:`PhysicsWorld.step` sets its own before stepping."""
        config = self.world_config(skill)
        if config not in self._worlds:
            self._worlds[config] = PhysicsWorld(config)
        return self._worlds[config]

    def skills(self) -> Mapping[str, SkillSpec]:
        return _SPECS

    def score_from_fraction(self, skill: str, fraction: float) -> float:
        """The score of a pour or scoop trial whose measured fraction is ``fraction`` (for
        recorded trials imported with a ``fraction`` column)."""
        return score_from_fraction(skill, fraction)

    def _spec(self, skill: str) -> SkillSpec:
        if skill not in _SPECS:
            raise KeyError(f"backend 'pybullet' has no skill {skill!r} (known: {KNOWN_SKILLS})")
        return _SPECS[skill]

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        """Randomly scaled kitchenware dimensions (push: block and distance), shape
        ``(d_context,)`` in the units of the skill's context space."""
        self._spec(skill)
        return _CONTEXTS[skill](rng)

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        """The tool path (cup tilt, spoon path, stirrer circles, fingertip pad) stays clear of
        the vessel and the table: ``(n,)``."""
        spec = self._spec(skill)
        batch = as_batch(controls, spec.control.dim)
        return _VALIDITY[skill](np.asarray(context, dtype=float), batch)

    def run_trial(
        self, skill: str, context: np.ndarray, control: np.ndarray, seed: int
    ) -> TrialResult:
        """Simulate one trial; deterministic given ``seed`` (invalid controls not simulated)."""
        return self._run(skill, context, control, seed, None)

    def record_trial(
        self,
        skill: str,
        context: np.ndarray,
        control: np.ndarray,
        seed: int,
        every: int = 8,
        camera: Camera | None = None,
    ) -> tuple[TrialResult, list[np.ndarray]]:
        """Like :meth:`run_trial`, also returning RGB frames ``(240, 320, 3)`` uint8 taken
        every ``every`` steps (TinyRenderer; for ``--render out.gif``)."""
        recorder = FrameRecorder(self.world_for(skill).client, every, camera)
        result = self._run(skill, context, control, seed, recorder)
        return result, recorder.frames

    def settings_for(self, skill: str) -> SkillSettings:
        """This backend's simulation settings of ``skill``."""
        return {"pour": self.pour_settings, "scoop": self.scoop_settings,
                "push": self.push_settings, "stir": self.stir_settings}[skill]

    def _run(
        self,
        skill: str,
        context: np.ndarray,
        control: np.ndarray,
        seed: int,
        on_step: StepCallback | None,
    ) -> TrialResult:
        context, control, rejected = precheck_trial(self._spec(skill), context, control)
        if rejected is not None:
            return rejected
        world = self.world_for(skill)
        physics = self._physics(world, skill, context, control, int(seed))
        settings = self.settings_for(skill)
        failure_score = self._spec(skill).invalid_score

        def trial(step: StepCallback | None) -> TrialResult:
            try:
                return run_skill_trial(physics, skill, context, control, int(seed), settings,
                                       step, check=False)
            except RobotFailure as failure:
                return failure.result(failure_score)

        # A diverged simulation (NaN, bodies flung away) makes an invalid trial.
        return run_guarded(bullet_guard(world.client), trial, on_step, failure_score)

    def _physics(self, world: PhysicsWorld, skill: str, context: np.ndarray,
                 control: np.ndarray, seed: int) -> BulletTrialPhysics:
        """Free-floating tools, or the Panda carrying the tool along the skill's path."""
        if self.robot == "none":
            return BulletTrialPhysics(world)
        if skill not in ROBOT_SKILLS:
            raise ValueError(f"robot {self.robot!r} runs {', '.join(ROBOT_SKILLS)} trials only, "
                             f"not {skill}")
        preview = _PREVIEWS[skill](context, control)
        bearings, anchor = SKILL_BEARINGS[skill]
        return RobotTrialPhysics(world, preview, self.robot_settings, seed, bearings, anchor)

    def close(self) -> None:
        for world in self._worlds.values():
            world.close()
        self._worlds.clear()
