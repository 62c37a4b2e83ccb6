"""bench/push_sensitivity.py: robustness and agreement bookkeeping, and a small real run on
the fidelity row's own inputs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bench import fidelity, push_sensitivity


def test_a_shift_moves_only_the_lateral_offset_by_a_fraction_of_the_side() -> None:
    context = np.array([0.05, 0.3, 0.5, 0.15])
    control = np.array([0.5, 0.1, 0.2, 0.01])
    moved = push_sensitivity.shifted_control(context, control, 1e-4)
    np.testing.assert_allclose(moved, [0.5, 0.1, 0.2 + 0.002, 0.01])
    assert control[2] == 0.2  # the input is not changed in place


def test_engine_summary_counts_robust_inputs_and_flips_per_shift() -> None:
    labels = np.array([[1, 1, 1],    # robust success
                       [0, 0, 0],    # robust failure
                       [1, 0, 1],    # flips under the first shift
                       [0, 1, 1]],   # flips under both
                      dtype=bool)
    summary = push_sensitivity.engine_summary(labels, (-0.1, 0.1))
    assert summary["robust"]["count"] == 2 and summary["robust"]["n"] == 4
    assert summary["flips_per_shift"] == {"-0.1": 2, "+0.1": 1}
    assert summary["unstable_inputs"] == [2, 3]
    assert summary["success_as_drawn"] == pytest.approx(0.5)


def test_cross_summary_restricts_agreement_to_the_robust_inputs() -> None:
    bullet = np.array([[1, 1, 1], [0, 0, 0], [1, 0, 0], [0, 0, 0]], dtype=bool)
    sapien = np.array([[1, 1, 1], [1, 1, 1], [0, 0, 0], [0, 0, 0]], dtype=bool)
    cross = push_sensitivity.cross_summary(bullet, sapien)
    assert cross["agreement_all"]["count"] == 2  # inputs 0 and 3
    assert (cross["agreement_robust_on_pybullet"]["count"],
            cross["agreement_robust_on_pybullet"]["n"]) == (2, 3)  # input 2 is unstable
    # Majority labels: input 2 is a PyBullet failure in 2 of 3 runs, so it agrees there.
    assert cross["agreement_majority"]["count"] == 3
    assert [d["input"] for d in cross["disagreements"]] == [1, 2]
    assert cross["disagreements"][1]["pybullet_robust"] is False


def test_bad_arguments_exit_with_status_2() -> None:
    for argv in (["--trials", "0"], ["--shifts-mm", "0"], ["--shifts-mm", "9"],
                 ["--pybullet-breaking-m", "0"]):
        with pytest.raises(SystemExit) as stop:
            push_sensitivity.parse_args(argv)
        assert stop.value.code == 2


def test_a_small_run_uses_the_fidelity_rows_inputs_and_labels(tmp_path: Path) -> None:
    pytest.importorskip("sapien")
    out = tmp_path / "sensitivity.json"
    assert push_sensitivity.main(["--trials", "3", "--shifts-mm", "0.1", "--out", str(out),
                                  "--quiet"]) == 0
    summary = json.loads(out.read_text())
    cache, row_out = tmp_path / "trials.jsonl", tmp_path / "fidelity.json"
    assert fidelity.main(["--rows", "3d-push-engine", "--trials", "3", "--cache", str(cache),
                          "--out", str(row_out), "--quiet"]) == 0
    row_labels: dict[str, list[int]] = {"pybullet": [0] * 3, "sapien": [0] * 3}
    for line in cache.read_text().splitlines():
        record = json.loads(line)
        row_labels[record["setting"]][record["seed"]] = int(fidelity.is_success(record))
    for engine in ("pybullet", "sapien"):
        labels = summary["engines"][engine]["labels"]
        assert [run[0] for run in labels] == row_labels[engine]  # as drawn = the row's trial
        assert all(len(run) == 2 for run in labels)
    agree = sum(a == b for a, b in zip(row_labels["pybullet"], row_labels["sapien"],
                                        strict=True))
    assert summary["cross"]["agreement_all"]["count"] == agree
