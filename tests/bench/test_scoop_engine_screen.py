"""Issue #21's fit-set screen summaries (``bench/scoop_engine_diag.py --fit-summary`` and
``bench/scoop_pybullet_spoon.py --summary``) on hand-made lines: no simulation."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("pybullet")

from bench.fidelity import setting_version
from bench.scoop_engine_diag import fit_summary
from bench.scoop_pybullet_spoon import _fraction, summarise


def _lines(path: Path, rows: list[dict]) -> Path:
    path.write_text("".join(json.dumps(row) + "\n" for row in rows))
    return path


def _cache_row(engine: str, version: str, seed: int, score: float) -> dict:
    return {"key": f"{engine}@v{version}|scoop|{seed}|0", "setting": engine, "skill": "scoop",
            "seed": seed, "score": score, "valid": True}


def _rerun(index: int, cfg: dict, score: float, capacity: int, spoon: int) -> dict:
    return {"index": index, "engine": "sapien", "cfg": cfg, "score": score, "valid": True,
            "info": {"spoon_capacity": capacity, "beads_in_spoon_end": spoon}}


def test_fit_summary_counts_agreement_bias_capacity_and_spoonful_per_setting(
        tmp_path: Path) -> None:
    pyb = setting_version("pybullet", "scoop")
    # PyBullet: input 0 fails at fraction 0.35 (score -0.5), input 1 succeeds fully (1.0).
    cache = _lines(tmp_path / "cache.jsonl", [
        _cache_row("pybullet", pyb, 0, -0.5), _cache_row("pybullet", pyb, 1, 1.0),
        _cache_row("sapien", "3", 0, 0.5), _cache_row("sapien", "3", 1, 1.0)])
    reruns = _lines(tmp_path / "reruns.jsonl", [
        _rerun(0, {}, 0.5, 8, 7), _rerun(1, {}, 1.0, 10, 10),
        _rerun(0, {"x": 1}, -0.5, 10, 4), _rerun(1, {"x": 1}, 1.0, 10, 10)])
    capacities = _lines(tmp_path / "cap.jsonl", [{"index": 0, "capacity": 10},
                                                 {"index": 1, "capacity": 10}])
    by_cfg = {json.dumps(s["cfg"]): s for s in fit_summary([reruns], cache, capacities)}
    v3, other = by_cfg["{}"], by_cfg['{"x": 1}']
    assert (v3["agree_new"], v3["agree_v3"]) == (1, 1)
    assert (other["agree_new"], other["agree_v3"]) == (2, 1)
    # SAPIEN v3's fraction on input 0: 0.85 vs PyBullet's 0.35.
    assert v3["fraction_bias_new"] == pytest.approx(0.25)
    assert other["fraction_bias_new"] == pytest.approx(0.0)
    assert v3["capacity_ratio"] == pytest.approx(0.9)
    assert other["capacity_ratio_v3"] == pytest.approx(0.9)
    # PyBullet's spoonful on input 0: 0.35 x 10 = 3.5 beads; v3 7, the other setting 4.
    assert v3["spoonful_diff_beads"] == pytest.approx(1.75)
    assert other["spoonful_diff_beads"] == pytest.approx(0.25)


def test_pybullet_spoon_summary_puts_variants_next_to_both_engines(tmp_path: Path) -> None:
    assert _fraction(-1.0, True) == 0.0 and _fraction(1.0, True) == pytest.approx(1.0)
    assert _fraction(0.5, False) == 0.0
    lines = _lines(tmp_path / "out.jsonl", [
        {"index": 0, "variant": "heavy", "score": 1.0, "valid": True,
         "cached_pybullet_score": -0.5, "info": {"spoon_capacity": 9, "beads_in_spoon_end": 9}},
        {"index": 5, "variant": "heavy", "score": 1.0, "valid": True,  # no capacity: left out
         "cached_pybullet_score": -0.5, "info": {"spoon_capacity": 9, "beads_in_spoon_end": 9}}])
    capacities = _lines(tmp_path / "cap.jsonl", [{"index": 0, "capacity": 10}])
    sapien = _lines(tmp_path / "sap.jsonl", [_rerun(0, {}, 0.5, 8, 7),
                                             _rerun(0, {"x": 1}, -1.0, 1, 0)])
    (row,) = summarise(lines, capacities, sapien)
    assert row["variant"] == "heavy" and row["inputs"] == 1
    assert (row["capacity"], row["capacity_pybullet"], row["capacity_sapien_v3"]) == (9, 10, 8)
    assert row["spoonful_pybullet"] == pytest.approx(3.5)
    assert row["spoonful_sapien_v3"] == 7
    assert (row["labels_agree_sapien_v3"], row["labels_agree_pybullet"]) == (1, 0)
