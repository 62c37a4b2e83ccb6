"""bench/fidelity.py: Wilson intervals, the agreement summary, and a small real row that
resumes from its trial cache."""

from __future__ import annotations

import json
import math
from pathlib import Path

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
