"""The Kitchen3D :class:`~ltamp_cli.backends.protocol.SkillBackend` on SAPIEN (PhysX CPU).

Same skills, parameter spaces, context distribution, validity pre-checks and scores as the
PyBullet backend (``name = "sapien"``); see :mod:`.skills`. One backend owns one
:class:`~.world.SapienWorld`, created on first use and reset for every trial.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields

import numpy as np

from ltamp_cli.backends.protocol import SkillSpec, TrialResult, as_batch
from ltamp_cli.backends.pybullet.backend import KNOWN_SKILLS, Kitchen3DBackend, precheck_trial
from ltamp_cli.backends.sanity import run_guarded
from ltamp_cli.backends.sapien.guard import sapien_guard
from ltamp_cli.backends.sapien.render import (
    CameraView,
    FrameRecorder,
    RenderProbe,
    new_render_system,
    probe_render_device,
    require_renderer,
)
from ltamp_cli.backends.sapien.skills import SapienTrialPhysics
from ltamp_cli.backends.sapien.world import SapienWorld, SapienWorldConfig, physics_version
from ltamp_cli.backends.skills3d.physics import StepCallback
from ltamp_cli.backends.skills3d.pour import PourSettings
from ltamp_cli.backends.skills3d.push import PushSettings
from ltamp_cli.backends.skills3d.scoop import ScoopSettings
from ltamp_cli.backends.skills3d.stir import StirSettings
from ltamp_cli.backends.skills3d.trials import (
    SkillSettings,
    run_skill_trial,
    score_from_fraction,
)


class SapienKitchen3DBackend:
    """SAPIEN Kitchen3D: skills ``pour``, ``scoop``, ``push`` and ``stir``, headless on the CPU.

    Options: ``solver_iterations`` (PhysX position iterations, default 5 as in PyBullet),
    ``contact_offset`` (m), ``bead_friction_scale`` (see :class:`~.world.SapienWorldConfig`),
    and per-skill timing via ``pour_settings``/``scoop_settings``/``push_settings``/
    ``stir_settings``.
    """

    name = "sapien"

    def __init__(
        self,
        solver_iterations: int = 5,
        contact_offset: float = 0.002,
        bead_friction_scale: float | None = None,
        pour_settings: PourSettings | None = None,
        scoop_settings: ScoopSettings | None = None,
        push_settings: PushSettings | None = None,
        stir_settings: StirSettings | None = None,
    ) -> None:
        self.config = SapienWorldConfig(
            solver_position_iterations=int(solver_iterations),
            contact_offset=float(contact_offset),
            **(
                {}
                if bead_friction_scale is None
                else {"bead_friction_scale": float(bead_friction_scale)}
            ),
        )
        self.pour_settings = pour_settings or PourSettings()
        self.scoop_settings = scoop_settings or ScoopSettings()
        self.push_settings = push_settings or PushSettings()
        self.stir_settings = stir_settings or StirSettings()
        # The pre-checks, specs and contexts are the PyBullet backend's, never its physics.
        self._kinematics = Kitchen3DBackend()
        self._world: SapienWorld | None = None
        self._render_world: SapienWorld | None = None
        self._render_probe: RenderProbe | None = None

    @property
    def world(self) -> SapienWorld:
        """The backend's physics-only world (created lazily, reused across trials)."""
        if self._world is None:
            self._world = SapienWorld(self.config)
        return self._world

    def physics_tag(self, skill: str) -> str:
        """The physics ``skill``'s trials on this backend carry (``TrialRecord.physics``):
        ``sapien@v<physics_version(skill)>``, with ``+<field>=<value>`` for each world
        setting that departs from :class:`~.world.SapienWorldConfig`'s (a what-if's labels
        are not the shipped ones, so a file never mixes the two)."""
        self._kinematics.skills()[skill]  # KeyError for an unknown skill
        shipped = SapienWorldConfig()
        changed = [f"+{f.name}={getattr(self.config, f.name)}" for f in fields(self.config)
                   if getattr(self.config, f.name) != getattr(shipped, f.name)]
        return f"sapien@v{physics_version(skill)}" + "".join(changed)

    def skills(self) -> Mapping[str, SkillSpec]:
        return self._kinematics.skills()

    def score_from_fraction(self, skill: str, fraction: float) -> float:
        """The score of a pour or scoop trial whose measured fraction is ``fraction`` (for
        recorded trials imported with a ``fraction`` column)."""
        return score_from_fraction(skill, fraction)

    def _spec(self, skill: str) -> SkillSpec:
        specs = self.skills()
        if skill not in specs:
            raise KeyError(f"backend 'sapien' has no skill {skill!r} (known: {KNOWN_SKILLS})")
        return specs[skill]

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        """Randomly scaled kitchenware dimensions, shape ``(d_context,)`` metres (the same
        distribution and draws as the PyBullet backend)."""
        self._spec(skill)
        return self._kinematics.sample_context(skill, rng)

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        """The tool path stays clear of the bowl and table (engine-independent): ``(n,)``."""
        spec = self._spec(skill)
        return self._kinematics.is_valid(skill, context, as_batch(controls, spec.control.dim))

    def run_trial(
        self, skill: str, context: np.ndarray, control: np.ndarray, seed: int
    ) -> TrialResult:
        """Simulate one trial; deterministic given ``seed`` (invalid controls not simulated)."""
        return self._run(self.world, skill, context, control, seed, None)

    def render_probe(self) -> RenderProbe:
        """Whether SAPIEN can render here (probed once, in a child process)."""
        if self._render_probe is None:
            self._render_probe = probe_render_device()
        return self._render_probe

    def record_trial(
        self,
        skill: str,
        context: np.ndarray,
        control: np.ndarray,
        seed: int,
        every: int = 8,
        view: CameraView | None = None,
    ) -> tuple[TrialResult, list[np.ndarray]]:
        """Like :meth:`run_trial`, also returning RGB frames ``(240, 320, 3)`` uint8 taken
        every ``every`` steps. Raises :class:`~.render.RendererUnavailable` (one clear
        message) when SAPIEN has no rendering device here."""
        require_renderer(self.render_probe())
        if self._render_world is None:
            self._render_world = SapienWorld(self.config, render_system=new_render_system())
        recorder = FrameRecorder(self._render_world, every, view)
        result = self._run(self._render_world, skill, context, control, seed, recorder)
        return result, recorder.frames

    def settings_for(self, skill: str) -> SkillSettings:
        """This backend's simulation settings of ``skill``."""
        return {"pour": self.pour_settings, "scoop": self.scoop_settings,
                "push": self.push_settings, "stir": self.stir_settings}[skill]

    def _run(
        self,
        world: SapienWorld,
        skill: str,
        context: np.ndarray,
        control: np.ndarray,
        seed: int,
        on_step: StepCallback | None,
    ) -> TrialResult:
        context, control, rejected = precheck_trial(self._spec(skill), context, control)
        if rejected is not None:
            return rejected
        physics = SapienTrialPhysics(world)
        settings = self.settings_for(skill)
        # A diverged simulation (NaN, bodies flung away) makes an invalid trial.
        return run_guarded(
            sapien_guard(world),
            lambda step: run_skill_trial(physics, skill, context, control, int(seed), settings,
                                         step, check=False),
            on_step,
            self._spec(skill).invalid_score,
        )

    def close(self) -> None:
        for world in (self._world, self._render_world):
            if world is not None:
                world.close()
        self._world = None
        self._render_world = None
