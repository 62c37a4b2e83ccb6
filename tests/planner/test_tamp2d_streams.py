"""The tamp2d example's placement sampler: spread out early, dense later, inside the region."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.errors import SourceLocation
from ltamp_cli.planner.problem import load_streams_factory

ROOT = Path(__file__).resolve().parents[2]
WORLD = {"regions": {"goal": [4.0, 10.0]}, "blocks": {"a": {"width": 2.0}}}


def make_streams(world: dict[str, Any], seed: int) -> dict[str, Any]:
    """The domain's bindings, loaded as a problem file naming them would load them."""
    folder = ROOT / "domains" / "tamp2d"
    factory = load_streams_factory("streams.py", folder, SourceLocation(str(folder)))
    return dict(factory(world, np.random.default_rng(seed)))


def placements(seed: int, count: int) -> np.ndarray:
    streams = make_streams(WORLD, seed)
    generator = streams["sample-pose"]("a", "goal")
    return np.array([next(generator)[0] for _ in range(count)])


def test_placements_stay_in_the_region_and_fill_it() -> None:
    samples = placements(seed=0, count=60)
    assert samples.min() >= 5.0 and samples.max() <= 9.0  # centres keep the block inside
    gaps = np.diff(np.sort(np.concatenate([[5.0], samples, [9.0]])))
    # 60 uniform draws leave a largest gap of ~0.3 on average (L ln(n) / n); spread ones less.
    assert gaps.max() < 0.2


def test_second_placement_is_far_from_the_first() -> None:
    # Independent uniform draws are L/3 = 1.33 apart on average (L = 4); the sampler keeps
    # the farthest of several candidates, so two blocks fit side by side much sooner.
    first_gaps = [abs(float(np.subtract(*placements(seed, 2)))) for seed in range(200)]
    assert np.mean(first_gaps) > 2.0
