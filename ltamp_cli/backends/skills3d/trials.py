"""One Kitchen3D trial of a named skill on any engine's :class:`TrialPhysics`."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ltamp_cli.backends.protocol import TrialResult
from ltamp_cli.backends.skills3d.physics import StepCallback, TrialPhysics
from ltamp_cli.backends.skills3d.pour import POUR_TAU, PourSettings, run_pour
from ltamp_cli.backends.skills3d.push import PushSettings, run_push
from ltamp_cli.backends.skills3d.scoop import SCOOP_TAU, ScoopSettings, run_scoop
from ltamp_cli.backends.skills3d.scoring import piecewise_linear_score
from ltamp_cli.backends.skills3d.stir import StirSettings, run_stir

SkillSettings = PourSettings | ScoopSettings | PushSettings | StirSettings


#: Skills scored from a measured fraction (beads in the bowl, spoon filled) and their τ.
FRACTION_TAUS = {"pour": POUR_TAU, "scoop": SCOOP_TAU}


def score_from_fraction(skill: str, fraction: float) -> float:
    """The score of a ``skill`` trial whose measured fraction is ``fraction`` in ``[0, 1]``
    (what a simulated trial would score); ``ValueError`` for a skill not scored from one."""
    if skill not in FRACTION_TAUS:
        raise ValueError(f"skill {skill!r} is not scored from a measured fraction")
    return float(piecewise_linear_score(fraction, FRACTION_TAUS[skill]))


def run_skill_trial(
    physics: TrialPhysics,
    skill: str,
    context: np.ndarray,
    control: np.ndarray,
    seed: int,
    settings: SkillSettings | None = None,
    on_step: StepCallback | None = None,
    check: bool = True,
) -> TrialResult:
    """Simulate one trial of ``skill`` (``pour``, ``scoop``, ``push`` or ``stir``) with
    ``physics``; ``settings`` must be that skill's settings (``None``: its defaults)."""
    runs: dict[str, tuple[Callable[..., TrialResult], type]] = {
        "pour": (run_pour, PourSettings),
        "scoop": (run_scoop, ScoopSettings),
        "push": (run_push, PushSettings),
        "stir": (run_stir, StirSettings),
    }
    if skill not in runs:
        raise KeyError(f"no Kitchen3D skill {skill!r} (known: {', '.join(runs)})")
    run, settings_type = runs[skill]
    if settings is not None and not isinstance(settings, settings_type):
        raise TypeError(f"{skill} takes {settings_type.__name__}, not {type(settings).__name__}")
    return run(physics, context, control, int(seed), settings, on_step, check=check)
