"""Push and stir trials on SAPIEN: the same clearly good and clearly bad controls get the same
success labels as on PyBullet, and bead conservation holds in PhysX too."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sapien")

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.protocol import SkillBackend
from ltamp_cli.backends.pybullet.skills.pour import NOMINAL_CUP

PUSH_CONTEXT = np.array([0.05, 0.3, 0.5, 0.15])
PUSH_CONTROLS = {
    "good": (np.array([0.5, 0.1, 0.0, 0.15]), True),         # travels 15 cm to the goal
    "short": (np.array([0.5, 0.1, 0.0, 0.10]), False),       # stops 5 cm short
    "off_centre": (np.array([0.5, 0.1, 0.45, 0.15]), False),  # slips past the block's corner
}
STIR_CONTEXT = np.array([NOMINAL_CUP.top_diameter, NOMINAL_CUP.height, NOMINAL_CUP.base_diameter])
STIR_CONTROLS = {
    "good": (np.array([0.018, 0.02, 2.0, 0.1]), True),
    "above_rim": (np.array([0.018, 0.11, 2.0, 0.1]), False),
}


@pytest.fixture(scope="module")
def backends() -> dict[str, SkillBackend]:
    out = {name: load_backend(name) for name in ("pybullet", "sapien")}
    yield out
    for backend in out.values():
        backend.close()


@pytest.mark.parametrize("case", sorted(PUSH_CONTROLS))
def test_push_labels_agree(backends: dict[str, SkillBackend], case: str) -> None:
    control, success = PUSH_CONTROLS[case]
    results = {n: b.run_trial("push", PUSH_CONTEXT, control, seed=0) for n, b in backends.items()}
    for name, result in results.items():
        assert result.valid and (result.score > 0) == success, (name, result.info)
        assert result.outcome is not None and len(result.outcome) == 3, name
    # Same straight push, same block: the final positions are within a centimetre.
    a, b = (np.asarray(r.info["final_xy"]) for r in results.values())
    if case != "off_centre":  # a slipping corner contact is chaotic
        assert np.linalg.norm(a - b) < 0.01


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(STIR_CONTROLS))
def test_stir_labels_agree_and_beads_stay(backends: dict[str, SkillBackend], case: str) -> None:
    control, success = STIR_CONTROLS[case]
    for name, backend in backends.items():
        result = backend.run_trial("stir", STIR_CONTEXT, control, seed=0)
        assert result.valid and (result.score > 0) == success, (name, result.info)
        assert result.info["stirred"] == success
        assert result.info["beads_in_cup_end"] == result.info["beads_in_cup_start"]
        assert result.info["beads_lost"] == 0
