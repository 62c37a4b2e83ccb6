"""bench/scoop_misses.py: which θ* trials count as misses, the bead bed's depth estimate and
its bad-input exits (no physics here; the trials themselves are PyBullet runs)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from bench import scoop_misses


def test_failed_theta_star_takes_each_contexts_first_record(tmp_path: Path) -> None:
    rows = [  # per context: θ*'s trial first, then the random baseline's
        {"seed": 0, "context": [0.2], "control": [1.0], "score": 0.5, "valid": True},
        {"seed": 0, "context": [0.2], "control": [2.0], "score": -1.0, "valid": True},
        {"seed": 1, "context": [0.3], "control": [3.0], "score": -0.2, "valid": True},
        {"seed": 1, "context": [0.3], "control": [4.0], "score": 0.9, "valid": True},
        {"seed": 2, "context": [0.4], "control": [5.0], "score": 0.7, "valid": False},
    ]
    path = tmp_path / "eval.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    assert scoop_misses.failed_theta_star(path) == [(1, [0.3], [3.0], -0.2), (2, [0.4], [5.0], 0.7)]


def test_bed_depth_matches_the_frustum_volume_and_shrinks_with_the_base() -> None:
    # A bowl with equal base and top diameters is a cylinder: depth = volume / area.
    context = np.array([0.2, 0.09, 0.2, 0.2])
    beads = 250.0
    volume = beads * 4.0 / 3.0 * math.pi * scoop_misses.MEAN_BEAD_RADIUS_M**3 / scoop_misses.PACKING
    from ltamp_cli.backends.skills3d.scoop import ScoopContext

    inner = 0.1 - ScoopContext.from_array(context).bowl.thickness
    assert math.isclose(scoop_misses.bed_depth_m(context, beads), volume / (math.pi * inner**2),
                        rel_tol=1e-6)
    narrow = scoop_misses.bed_depth_m(np.array([0.166, 0.089, 0.098, 0.24]), beads)
    wide = scoop_misses.bed_depth_m(np.array([0.239, 0.091, 0.171, 0.21]), beads)
    assert narrow > 2.0 * wide > 0.0


def test_bad_arguments_exit_2(tmp_path: Path) -> None:
    out, summary = str(tmp_path / "o.jsonl"), str(tmp_path / "s.json")
    assert scoop_misses.main(["--model", "m", "--local", "0", "--out", out,
                              "--summary", summary]) == 2
    assert scoop_misses.main(["--model", "m", "--eval", str(tmp_path / "none.jsonl"),
                              "--out", out, "--summary", summary]) == 2
