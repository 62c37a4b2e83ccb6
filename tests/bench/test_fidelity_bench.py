"""bench/fidelity.py: Wilson intervals, the agreement summary, and a small real row that
resumes from its trial cache."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from bench import fidelity


def _wilson_by_formula(k: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return centre - half, centre + half


@pytest.mark.parametrize(("k", "n"), [(190, 200), (200, 200), (3, 7), (0, 5)])
def test_wilson_interval_is_the_wilson_score_interval(k: int, n: int) -> None:
    low, high = fidelity.wilson_interval(k, n)
    expected = _wilson_by_formula(k, n)
    assert low == pytest.approx(max(expected[0], 0.0), abs=1e-9)
    assert high == pytest.approx(min(expected[1], 1.0), abs=1e-9)


def _record(score: float | None, valid: bool = True, error: str | None = None) -> dict:
    return {"score": score, "valid": valid, "error": error, "cpu_s": 0.5}


def test_summary_counts_labels_disagreements_and_leaves_out_failed_trials() -> None:
    row = fidelity.Row("r", "pour", "fast", "ref")
    pairs = [
        [_record(0.5), _record(0.2)],                 # both succeed
        [_record(0.5), _record(-0.1)],                # fast only
        [_record(-1.0), _record(0.3)],                # reference only
        [_record(0.7, valid=False), _record(-0.2)],   # an invalid trial is a failure
        [_record(0.4), _record(None, False, "500 particles do not fit")],  # left out
    ]
    summary = fidelity.summarise(row, pairs)
    assert summary["trials"] == 4 and summary["errors"] == 1
    assert summary["agreement"] == pytest.approx(2 / 4)
    assert (summary["fast_only"], summary["reference_only"]) == (1, 1)
    assert summary["fast_success"] == pytest.approx(2 / 4)
    assert summary["reference_success"] == pytest.approx(2 / 4)
    assert summary["wilson95"] == pytest.approx(list(fidelity.wilson_interval(2, 4)))


def test_a_row_runs_real_trials_and_a_rerun_reuses_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("sapien")
    cache, out = tmp_path / "trials.jsonl", tmp_path / "fidelity.json"
    args = ["--rows", "3d-push-engine", "--trials", "4", "--cache", str(cache),
            "--out", str(out), "--quiet"]
    assert fidelity.main(args) == 0
    records = [json.loads(line) for line in cache.read_text().splitlines()]
    assert len(records) == 8 and {r["setting"] for r in records} == {"pybullet", "sapien"}
    by_input = {}
    for record in records:
        by_input.setdefault(record["seed"], {})[record["setting"]] = fidelity.is_success(record)
    agreement = sum(p["pybullet"] == p["sapien"] for p in by_input.values()) / 4
    first = json.loads(out.read_text())["rows"][0]
    assert first["trials"] == 4 and first["agreement"] == pytest.approx(agreement)
    # The push declares an outcome: each record keeps it, and the row sweeps the goal.
    assert all(len(r["outcome"]) == 3 for r in records)
    assert first["goal_sweep"]["units"] == 4 * fidelity.SWEEP_GOALS
    assert first["outcome_differences"]["inputs"] == 4
    assert "3d-push-engine" in capsys.readouterr().out

    with cache.open("a") as torn:
        torn.write('{"key": "half a li')  # a run stopped mid-write
    assert fidelity.main(args) == 0
    assert len(cache.read_text().splitlines()) == 9  # nothing was simulated again
    assert json.loads(out.read_text())["rows"][0] == first
    fidelity.append_record(cache, {"key": "next"})  # starts on a line of its own
    assert set(fidelity.load_cache(cache)) == {r["key"] for r in records} | {"next"}


def test_fresh_inputs_continue_the_same_draws_and_stored_inputs_are_reused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("sapien")
    cache, out, stored = (tmp_path / "trials.jsonl", tmp_path / "fidelity.json",
                          tmp_path / "inputs.json")
    base = ["--rows", "3d-push-engine", "--cache", str(cache), "--out", str(out), "--quiet"]
    assert fidelity.main([*base, "--trials", "3"]) == 0
    first_three = {r["seed"]: r for r in map(json.loads, cache.read_text().splitlines())}
    # Inputs 3-5 of a 6-input row: only they run, with trial seeds 3-5.
    assert fidelity.main([*base, "--trials", "6", "--first-input", "3",
                          "--inputs", str(stored)]) == 0
    records = [json.loads(line) for line in cache.read_text().splitlines()]
    assert sorted({r["seed"] for r in records}) == list(range(6))
    report = json.loads(out.read_text())
    assert report["first_input"] == 3 and report["rows"][0]["trials"] == 3
    kept = json.loads(stored.read_text())
    assert len(kept["inputs"]) == 6 and kept["settings"] == ["pybullet", "sapien"]
    for seed, record in first_three.items():  # the stored draws extend the 3-input row's
        assert kept["inputs"][seed] == pytest.approx(record["context"] + record["control"])

    def no_draws(*_args: object) -> None:
        raise AssertionError("the stored inputs were drawn again")

    monkeypatch.setattr(fidelity, "draw_inputs", no_draws)
    assert fidelity.main([*base, "--trials", "5", "--first-input", "3",
                          "--inputs", str(stored)]) == 0  # a prefix of the stored ones
    assert len(cache.read_text().splitlines()) == len(records)  # nothing simulated again
    assert json.loads(out.read_text())["rows"][0]["trials"] == 2
    with pytest.raises(SystemExit):
        fidelity.main([*base, "--trials", "3", "--first-input", "3"])


def test_the_placed_spoon_row_is_its_own_setting_with_its_own_keys() -> None:
    pytest.importorskip("sapien")
    backend = fidelity.SETTINGS["sapien-placed-spoon"]()
    try:
        assert backend.config.spoon_tool == "placed"  # type: ignore[attr-defined]
    finally:
        backend.close()
    shipped = fidelity.SETTINGS["sapien"]()
    try:
        assert shipped.config.spoon_tool == "kinematic"  # type: ignore[attr-defined]
    finally:
        shipped.close()
    rows = {row.name: row for row in fidelity.ROWS}
    assert rows["3d-scoop-placed-spoon"].reference == "sapien-placed-spoon"
    key = fidelity.trial_key("sapien-placed-spoon", "scoop", [0.2] * 4, [0.0] * 5, 7)
    assert key.startswith("sapien-placed-spoon@v3|scoop|7|")
    assert key != fidelity.trial_key("sapien", "scoop", [0.2] * 4, [0.0] * 5, 7)


def _push_record(final_x: float, rotation: float = 0.0, goal_x: float = 0.15,
                 outcome: bool = True) -> dict:
    """A push trial record: context (side, mass, friction, goal), control, its outcome."""
    from ltamp_cli.backends.skills3d.push import PUSH_SPEC

    context, control = [0.06, 0.3, 0.5, goal_x], [0.5, 0.1, 0.0, 0.1]
    score = float(PUSH_SPEC.outcome.scores(np.array([context]), np.array([control]),
                                           np.array([[final_x, 0.0, rotation]]))[0])
    record = {"score": score, "valid": True, "error": None, "cpu_s": 0.03,
              "context": context, "control": control}
    if outcome:
        record["outcome"] = [final_x, 0.0, rotation]
    return record


def test_goal_sweep_relabels_each_outcome_at_every_goal() -> None:
    from ltamp_cli.backends.skills3d.push import PUSH_SPEC, PUSH_TOLERANCE_M

    n = 64
    goals = np.random.default_rng(0).uniform(0.05, 0.25, size=n)
    same = [(_push_record(0.12), _push_record(0.12))]
    sweep = fidelity.goal_sweep(PUSH_SPEC, same, n_goals=n)
    assert sweep["agreement"] == 1.0 and sweep["inputs_with_a_disagreement"] == 0
    near = int((np.abs(goals - 0.12) < PUSH_TOLERANCE_M).sum())
    assert 0 < near < n and sweep["both_success"] == near

    # 6 cm apart: each end is a success only at the goals within 2.5 cm of it.
    apart = [(_push_record(0.10), _push_record(0.16))]
    sweep = fidelity.goal_sweep(PUSH_SPEC, apart, n_goals=n)
    fast = np.abs(goals - 0.10) < PUSH_TOLERANCE_M
    ref = np.abs(goals - 0.16) < PUSH_TOLERANCE_M
    assert sweep["both_success"] == 0 and sweep["either_success"] == int((fast | ref).sum())
    assert sweep["agreement"] == pytest.approx(float((fast == ref).mean()))
    assert sweep["fast_success"] == pytest.approx(float(fast.mean()))

    # A turned block fails at every goal; a record without an outcome keeps its own label.
    turned = [(_push_record(0.12), _push_record(0.12, rotation=0.2)),
              (_push_record(0.12), {**_push_record(0.12, outcome=False), "score": -1.0})]
    sweep = fidelity.goal_sweep(PUSH_SPEC, turned, n_goals=n)
    assert sweep["reference_success"] == 0.0 and sweep["both_success"] == 0
    assert sweep["inputs_with_a_disagreement"] == 2


def test_outcome_differences_per_declared_value_and_only_for_outcome_skills() -> None:
    from ltamp_cli.backends.skills3d.push import PUSH_SPEC

    kept = [(_push_record(0.10), _push_record(0.13, rotation=0.05)),
            (_push_record(0.20), _push_record(0.20)),
            (_push_record(0.20), _push_record(0.20, outcome=False))]  # not compared
    diff = fidelity.outcome_differences(PUSH_SPEC, kept)
    assert diff["inputs"] == 2
    assert diff["final_x (m)"]["max"] == pytest.approx(0.03)
    assert diff["final_x (m)"]["median"] == pytest.approx(0.015)
    assert diff["rotation (rad)"]["max"] == pytest.approx(0.05)
    row = fidelity.Row("r", "push", "a", "b")
    summary = fidelity.summarise(row, [list(pair) for pair in kept], PUSH_SPEC)
    # At the drawn goal (0.15 m) only the block that ended at 0.13 m succeeds.
    assert summary["either_success"] == 1 and summary["both_success"] == 0
    assert summary["goal_sweep"]["units"] == 3 * fidelity.SWEEP_GOALS
    plain = [[_record(0.5), _record(0.2)]]  # cached before outcomes, or a skill without one
    assert "goal_sweep" not in fidelity.summarise(row, plain, PUSH_SPEC)
