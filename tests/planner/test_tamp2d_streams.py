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


TABLE_WORLD = {"regions": {"table": [-15.0, 15.0]},
               "blocks": {"a": {"width": 2.0}, "c": {"width": 2.5}}}
C_POSE = 0.0
CLEARANCE = (2.0 + 2.5) / 2.0  # a closer to c than this collides with it


def placements_beside_c(seed: int, count: int) -> np.ndarray:
    """Placements of a on the table after the streams have seen c standing at 0."""
    streams = make_streams(TABLE_WORLD, seed)
    assert streams["test-cfree"].function("c", C_POSE, "a", -10.0) is True
    generator = streams["sample-pose"]("a", "table")
    return np.array([next(generator)[0] for _ in range(count)])


def test_first_placements_keep_clear_of_other_blocks_known_poses() -> None:
    # Uniform draws hit c's 4.5-wide footprint (of 28) one time in six: ~50 of 300 here.
    first = np.concatenate([placements_beside_c(seed, 3) for seed in range(100)])
    assert (np.abs(first - C_POSE) >= CLEARANCE).all()


def test_avoided_spots_are_still_sampled_later() -> None:
    # A preference, not a rule: the spot c stands on may be the only one left once c moves.
    samples = placements_beside_c(seed=0, count=80)
    inside = np.sort(samples[np.abs(samples - C_POSE) < CLEARANCE])
    gaps = np.diff(np.concatenate([[C_POSE - CLEARANCE], inside, [C_POSE + CLEARANCE]]))
    assert gaps.max() < 1.0


def test_where_every_spot_collides_the_least_overlapping_one_comes_first() -> None:
    # The goal region (centres 5-9) holds c at 7: a's placement should hug an edge so that
    # another block fits beside it once c leaves. Uniform draws are 1.0 from 7 on average.
    world = {"regions": {"goal": [4.0, 10.0]},
             "blocks": {"a": {"width": 2.0}, "c": {"width": 2.5}}}
    distances = []
    for seed in range(100):
        streams = make_streams(world, seed)
        streams["test-cfree"].function("c", 7.0, "a", 5.0)
        distances.append(abs(next(streams["sample-pose"]("a", "goal"))[0] - 7.0))
    assert np.mean(distances) > 1.5
