"""bench/label_stability.py: shifts in control units, stability and agreement bookkeeping,
the input subsets, and a small real run on a fidelity row's own inputs and cache (the 3D
push: its trials cost milliseconds)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bench import fidelity, label_stability
from ltamp_cli.backends.skills3d.push import PUSH_SPEC
from ltamp_cli.backends.skills3d.scoop import SCOOP_SPEC


def test_a_shift_in_metres_and_one_in_fractions_of_a_context_length() -> None:
    context = np.array([0.2, 0.08, 0.1, 0.15])  # bowl diameter 0.2 m
    control = np.array([0.3, -0.2, 0.1, 0.01, 0.02])
    depth = label_stability.parse_shift("scoop_z:-0.1", SCOOP_SPEC)
    start = label_stability.parse_shift("start_y:+0.1", SCOOP_SPEC)
    assert start.per == "bowl_diameter"  # from the unit "× bowl diameter"
    np.testing.assert_allclose(label_stability.shifted_control(SCOOP_SPEC, context, control,
                                                               depth),
                               [0.3, -0.2, 0.1, 0.01 - 1e-4, 0.02])
    np.testing.assert_allclose(label_stability.shifted_control(SCOOP_SPEC, context, control,
                                                               start),
                               [0.3 + 1e-4 / 0.2, -0.2, 0.1, 0.01, 0.02])
    assert control[3] == 0.01  # the input is not changed in place


@pytest.mark.parametrize("text", ["scoop_z", "scoop_z:x", "depth:0.1", "scoop_z:0",
                                  "scoop_z:9", "start_y:0.1/cup_height"])
def test_bad_scoop_shifts_say_what_is_wrong(text: str) -> None:
    with pytest.raises(ValueError, match="shift"):
        label_stability.parse_shift(text, SCOOP_SPEC)


def test_a_unit_that_names_no_context_length_needs_it_spelled_out() -> None:
    # The push's lateral offset is "× block side"; its context length is "block_size".
    with pytest.raises(ValueError, match="DIM:MM/CTX"):
        label_stability.parse_shift("lateral_offset:0.1", PUSH_SPEC)
    with pytest.raises(ValueError, match="not metres"):
        label_stability.parse_shift("speed:0.1", PUSH_SPEC)  # m/s
    shift = label_stability.parse_shift("lateral_offset:0.1/block_size", PUSH_SPEC)
    moved = label_stability.shifted_control(PUSH_SPEC, np.array([0.05, 0.3, 0.5, 0.15]),
                                            np.array([0.5, 0.1, 0.2, 0.01]), shift)
    np.testing.assert_allclose(moved, [0.5, 0.1, 0.2 + 0.002, 0.01])


def test_stability_counts_robust_inputs_and_self_agreement_per_shift() -> None:
    labels = np.array([[1, 1, 1], [0, 0, 0], [1, 0, 1], [0, 1, 1]], dtype=bool)
    s = label_stability.stability(labels, ["a", "b"])
    assert (s["robust"]["count"], s["robust"]["n"]) == (2, 4)
    assert s["self_agreement"]["a"]["count"] == 2  # inputs 2 and 3 flip under a
    assert s["self_agreement"]["b"]["count"] == 3  # input 3 flips under b
    assert s["self_agreement_mean"] == pytest.approx(5 / 8)
    assert s["success_as_drawn"]["count"] == 2


def test_agreement_splits_directions_and_restricts_to_robust_reference_inputs() -> None:
    fast = np.array([1, 0, 0, 0], dtype=bool)
    reference = np.array([1, 1, 0, 1], dtype=bool)
    robust = np.array([True, False, True, True])
    a = label_stability.agreement(fast, reference, robust)
    assert a["all"]["count"] == 2 and a["reference_only"] == 2 and a["fast_only"] == 0
    assert (a["reference_robust"]["count"], a["reference_robust"]["n"]) == (2, 3)


def test_the_random_subset_is_seeded_and_the_disagreeing_inputs_sorted() -> None:
    bad, chosen = label_stability.choose_inputs(50, [9, 3, 9], 10, subset_seed=4)
    assert bad == [3, 9]
    assert chosen == label_stability.choose_inputs(50, [], 10, subset_seed=4)[1]
    assert len(set(chosen)) == 10 and all(0 <= i < 50 for i in chosen)
    assert chosen != label_stability.choose_inputs(50, [], 10, subset_seed=5)[1]
    assert label_stability.choose_inputs(4, [], None, 0)[1] == [0, 1, 2, 3]


def test_bad_arguments_exit_with_status_2(tmp_path: Path) -> None:
    inputs = tmp_path / "inputs.json"
    inputs.write_text(json.dumps({"skill": "push", "seed": 0, "inputs": [[0.0] * 8]}))
    base = ["--inputs", str(inputs), "--cache", str(tmp_path / "c.jsonl")]
    for argv in ([*base, "--settings", "pybullet", "--trials", "0"],
                 [*base, "--settings", "pybullet", "--run", "sapien"],
                 [*base, "--settings", "pybullet", "--random", "0"],
                 [*base, "--settings", "pybullet", "--shard", "2/2"],
                 [*base, "--settings", "nonesuch"]):
        with pytest.raises(SystemExit) as stop:
            label_stability.parse_args(argv)
        assert stop.value.code == 2
    # More inputs asked for than the file holds, and a bad shift: one line, status 2.
    assert label_stability.main([*base, "--settings", "pybullet", "--trials", "3"]) == 2
    assert label_stability.main([*base, "--settings", "pybullet", "--trials", "1",
                                 "--shifts", "lateral_offset:0.1"]) == 2


def test_a_small_run_reads_the_rows_trials_and_adds_only_the_shifted_ones(
        tmp_path: Path) -> None:
    inputs, row_cache = tmp_path / "inputs.json", tmp_path / "row.jsonl"
    assert fidelity.main(["--rows", "3d-push-solver", "--trials", "4", "--inputs",
                          str(inputs), "--cache", str(row_cache), "--out",
                          str(tmp_path / "row.json"), "--quiet"]) == 0
    cache, out = tmp_path / "shifted.jsonl", tmp_path / "stability.json"
    argv = ["--inputs", str(inputs), "--trials", "4", "--read-cache", str(row_cache),
            "--cache", str(cache), "--settings", "pybullet-solver-50", "pybullet",
            "--run", "pybullet-solver-50", "pybullet", "--shifts",
            "lateral_offset:-0.1/block_size", "lateral_offset:+0.1/block_size",
            "--disagreeing", "pybullet", "pybullet-solver-50", "--out", str(out), "--quiet"]
    assert label_stability.main(argv) == 0
    # The as-drawn trials came from the row's cache: only 4 inputs x 2 settings x 2 shifts ran.
    assert len(cache.read_text().splitlines()) == 16
    summary = json.loads(out.read_text())
    row = {json.loads(line)["key"]: json.loads(line) for line in row_cache.read_text().splitlines()}
    for setting in ("pybullet", "pybullet-solver-50"):
        labels = summary["groups"]["random"]["settings"][setting]["labels"]
        assert sorted(labels, key=int) == ["0", "1", "2", "3"]
        as_drawn = [int(fidelity.is_success(r)) for r in sorted(
            (r for r in row.values() if r["setting"] == setting), key=lambda r: r["seed"])]
        assert [labels[str(i)][0] for i in range(4)] == as_drawn
        assert all(len(runs) == 3 for runs in labels.values())
    # A rerun finds everything cached and runs nothing.
    assert label_stability.main(argv) == 0
    assert len(cache.read_text().splitlines()) == 16


def test_the_sign_test_of_one_sided_disagreements() -> None:
    from bench.scoop_solver_summary import sign_test

    assert sign_test(8, 8) == pytest.approx(2 / 256)  # all 8 one way: a bias, p < 0.01
    assert sign_test(4, 8) == 1.0 and sign_test(0, 0) == 1.0
    assert sign_test(5, 6) == pytest.approx(2 * 7 / 64)


def test_the_scoop_summary_compares_cached_labels_by_key() -> None:
    from bench.scoop_solver_summary import KEY_NAMES, compare

    inputs = np.array([[0.2, 0.08, 0.12, 0.15, 0.1, -0.1, 0.0, 0.0, 0.02],
                       [0.2, 0.08, 0.12, 0.15, 0.3, -0.2, 0.1, 0.01, 0.03]])
    cache = {}
    for i, (fast_score, ref_score) in enumerate(((-0.5, 0.4), (0.2, 0.3))):
        for setting, score in (("pybullet", fast_score), ("pybullet-solver-50", ref_score)):
            key = fidelity.trial_key(setting, "scoop", inputs[i, :4], inputs[i, 4:], i)
            key = key.replace(key.split("|")[0], KEY_NAMES[setting])  # frozen names
            cache[key] = {"key": key, "score": score, "valid": True, "error": None,
                          "cpu_s": 1.0}
    row = compare(cache, inputs, 0, "pybullet", "pybullet-solver-50", [0, 1])
    assert (row["n"], row["agree"], row["reference_only"], row["fast_only"]) == (2, 1, 1, 0)
    assert row["disagreeing_inputs"] == [0] and row["both_success"] == 1
    assert not row["passes_0.95_rule"]
