"""The Kitchen3D :class:`~ltamp_cli.backends.protocol.SkillBackend` (PyBullet).

One backend owns one :class:`~.world.PhysicsWorld` (its own headless client), created on
first use and reset, not recreated, for every trial.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import MappingProxyType

import numpy as np

from ltamp_cli.backends.protocol import SkillSpec, TrialResult, as_batch
from ltamp_cli.backends.pybullet.render import Camera, FrameRecorder
from ltamp_cli.backends.pybullet.skills.common import StepCallback
from ltamp_cli.backends.pybullet.skills.pour import (
    POUR_SPEC,
    PourSettings,
    check_pour,
    pour_is_valid,
    run_pour,
    sample_pour_context,
)
from ltamp_cli.backends.pybullet.skills.scoop import (
    SCOOP_SPEC,
    ScoopSettings,
    check_scoop,
    run_scoop,
    sample_scoop_context,
    scoop_is_valid,
)
from ltamp_cli.backends.pybullet.world import PhysicsWorld, WorldConfig

_SPECS: Mapping[str, SkillSpec] = MappingProxyType({"pour": POUR_SPEC, "scoop": SCOOP_SPEC})


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
    verdict = (check_pour if spec.name == "pour" else check_scoop)(context, control)
    if not verdict.valid:
        return context, control, TrialResult(spec.invalid_score, False,
                                              {"reason": verdict.reason})
    return context, control, None


class Kitchen3DBackend:
    """PyBullet Kitchen3D: skills ``pour`` and ``scoop``.

    Options: ``gui`` (open a PyBullet window instead of ``DIRECT``), ``solver_iterations``,
    and per-skill timing via ``pour_settings``/``scoop_settings``.
    """

    name = "pybullet"

    def __init__(
        self,
        gui: bool = False,
        solver_iterations: int = 5,
        pour_settings: PourSettings | None = None,
        scoop_settings: ScoopSettings | None = None,
    ) -> None:
        self.config = WorldConfig(gui=bool(gui), solver_iterations=int(solver_iterations))
        self.pour_settings = pour_settings or PourSettings()
        self.scoop_settings = scoop_settings or ScoopSettings()
        self._world: PhysicsWorld | None = None

    @property
    def world(self) -> PhysicsWorld:
        """The backend's physics world (connected lazily, reused across trials)."""
        if self._world is None:
            self._world = PhysicsWorld(self.config)
        return self._world

    def skills(self) -> Mapping[str, SkillSpec]:
        return _SPECS

    def _spec(self, skill: str) -> SkillSpec:
        if skill not in _SPECS:
            raise KeyError(f"backend 'pybullet' has no skill {skill!r} (known: pour, scoop)")
        return _SPECS[skill]

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        """Randomly scaled kitchenware dimensions, shape ``(d_context,)`` metres."""
        self._spec(skill)
        return sample_pour_context(rng) if skill == "pour" else sample_scoop_context(rng)

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        """The tool path (cup tilt or spoon path) stays clear of the bowl and table: ``(n,)``."""
        spec = self._spec(skill)
        batch = as_batch(controls, spec.control.dim)
        check = pour_is_valid if skill == "pour" else scoop_is_valid
        return check(np.asarray(context, dtype=float), batch)

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
        recorder = FrameRecorder(self.world.client, every, camera)
        result = self._run(skill, context, control, seed, recorder)
        return result, recorder.frames

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
        run: Callable[..., TrialResult]
        if skill == "pour":
            run, settings = run_pour, self.pour_settings
        else:
            run, settings = run_scoop, self.scoop_settings
        return run(self.world, context, control, int(seed), settings, on_step, check=False)

    def close(self) -> None:
        if self._world is not None:
            self._world.close()
            self._world = None
