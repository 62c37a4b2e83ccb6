"""The Kitchen2D :class:`~ltamp_cli.backends.protocol.SkillBackend` and a trial renderer."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType, ModuleType
from typing import Any

import numpy as np
from PIL import Image

from ltamp_cli.backends.box2d.guard import Box2DGuard
from ltamp_cli.backends.box2d.render import FrameRecorder
from ltamp_cli.backends.box2d.skills import pour, push, scoop
from ltamp_cli.backends.box2d.world import Observer
from ltamp_cli.backends.protocol import SkillSpec, TrialResult, skill_spec
from ltamp_cli.backends.sanity import PhysicsDiverged

_MODULES: Mapping[str, ModuleType] = MappingProxyType({"pour": pour, "scoop": scoop, "push": push})


@dataclass(frozen=True)
class Kitchen2DConfig:
    """Per-skill simulation settings (see each skill module)."""

    pour: pour.PourConfig = field(default_factory=pour.PourConfig)
    scoop: scoop.ScoopConfig = field(default_factory=scoop.ScoopConfig)
    push: push.PushConfig = field(default_factory=push.PushConfig)


class Kitchen2DBackend:
    """Box2D Kitchen2D: skills ``pour`` (4 + 4), ``scoop`` (2 + 7) and ``push`` (2 + 4).

    Options: ``pour_particles`` (int) overrides the pour's particle count. Every trial
    builds its own small Box2D world (milliseconds), which keeps trials deterministic
    given their seed whatever ran before them.
    """

    name = "box2d"

    def __init__(self, pour_particles: int | None = None, **options: Any) -> None:
        if options:
            raise TypeError(f"unknown box2d backend options: {', '.join(sorted(options))}")
        pour_config = pour.PourConfig()
        if pour_particles is not None:
            pour_config = pour.PourConfig(n_particles=int(pour_particles))
        self.config = Kitchen2DConfig(pour=pour_config)

    def skills(self) -> Mapping[str, SkillSpec]:
        return MappingProxyType({name: module.SPEC for name, module in _MODULES.items()})

    def _skill(self, skill: str) -> tuple[ModuleType, Any]:
        skill_spec(self, skill)  # raises KeyError naming the known skills
        return _MODULES[skill], getattr(self.config, skill)

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        """Uniform over the paper's context ranges, shape ``(d_context,)``."""
        return skill_spec(self, skill).context.sample_uniform(rng, 1)[0]

    def score_from_fraction(self, skill: str, fraction: float) -> float:
        """The score of a trial whose measured fraction (particles that reached the target
        cup for ``pour``, spoon capacity filled for ``scoop``) is ``fraction`` in ``[0, 1]``:
        recorded trials imported with a ``fraction`` column get the score simulated ones
        would. ``ValueError`` for a skill not scored from a fraction (push)."""
        scores = {"pour": pour.score, "scoop": scoop.score}
        if skill not in scores:
            raise ValueError(f"skill {skill!r} is not scored from a measured fraction")
        return float(scores[skill](fraction))

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        module, config = self._skill(skill)
        spec = module.SPEC
        batch = np.asarray(controls, dtype=float).reshape(-1, spec.control.dim)
        return module.valid_mask(np.asarray(context, dtype=float), batch, config)

    def run_trial(
        self,
        skill: str,
        context: np.ndarray,
        control: np.ndarray,
        seed: int,
        observer: Observer | None = None,
    ) -> TrialResult:
        module, config = self._skill(skill)
        context = np.asarray(context, dtype=float).reshape(module.SPEC.context.dim)
        control = np.asarray(control, dtype=float).reshape(module.SPEC.control.dim)
        guard = Box2DGuard(observer)  # a diverged simulation makes an invalid trial
        try:
            result = module.run(context, control, int(seed), config, guard)
            guard.final_check()
        except PhysicsDiverged as diverged:
            return diverged.result(module.SPEC.invalid_score)
        return result

    def close(self) -> None:
        """Nothing to release: worlds live only as long as their trial."""


def render_trial(
    skill: str,
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    path: str | Path | None = None,
    *,
    backend: Kitchen2DBackend | None = None,
    every: int = 5,
    scale: float = 30.0,
) -> tuple[TrialResult, list[Image.Image]]:
    """Run one trial while recording frames; save a GIF/PNG to ``path`` if given.

    The view follows what moves (and the goal marker of a push); every frame is captioned
    with the skill, its context and its control. Returns the trial result (identical to an
    unrecorded run) and the PIL frames (uncaptioned).
    """
    backend = backend or Kitchen2DBackend()
    spec = skill_spec(backend, skill)
    recorder = FrameRecorder(every=every, scale=scale, follow=True)
    recorder.caption = f"{skill}  " + "  ".join(
        f"{name}={float(value):.2f}" for name, value in
        zip((*spec.context.names, *spec.control.names),
            (*np.ravel(context), *np.ravel(control)), strict=True))
    result = backend.run_trial(skill, context, control, seed, observer=recorder)
    frames = recorder.frames
    if path is not None and frames:
        recorder.save(path)
    return result, frames
