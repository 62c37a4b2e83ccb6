"""bench/cache_reproduce.py: reruns cached fidelity trials and compares them exactly."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench import cache_reproduce, fidelity


def test_bad_arguments_exit_with_status_2(tmp_path: Path) -> None:
    cache = tmp_path / "trials.jsonl"
    cache.write_text("")
    out = str(tmp_path / "out.json")
    for argv in (["--cache", str(tmp_path / "missing.jsonl"), "--skill", "push", "--out", out],
                 ["--cache", str(cache), "--skill", "push", "--n", "0", "--out", out],
                 ["--cache", str(cache), "--skill", "push", "--setting", "bullet", "--out", out],
                 ["--cache", str(cache), "--skill", "push", "--interleave", "wipe",
                  "--out", out]):
        with pytest.raises(SystemExit) as stop:
            cache_reproduce.parse_args(argv)
        assert stop.value.code == 2
    # Too few records of the current physics version: one line, status 2.
    assert cache_reproduce.main(["--cache", str(cache), "--skill", "push", "--out", out,
                                 "--quiet"]) == 2


def test_cached_push_trials_reproduce_and_a_changed_one_does_not(tmp_path: Path) -> None:
    cache, row_out = tmp_path / "trials.jsonl", tmp_path / "row.json"
    assert fidelity.main(["--rows", "3d-push-solver", "--trials", "2", "--cache", str(cache),
                          "--out", str(row_out), "--quiet"]) == 0
    out = tmp_path / "reproduce.json"
    argv = ["--cache", str(cache), "--skill", "push", "--n", "2", "--interleave", "pour",
            "--out", str(out), "--quiet"]
    assert cache_reproduce.main(argv) == 0
    result = json.loads(out.read_text())["results"][0]
    assert (result["identical"], result["n"]) == (2, 2)
    assert [r["seed"] for r in result["records"]] == [0, 1]  # the lowest seeds, in order
    # A record whose cached score differs by 1e-12 no longer counts as reproduced.
    lines = [json.loads(line) for line in cache.read_text().splitlines()]
    for record in lines:
        if record["setting"] == "pybullet" and record["seed"] == 1:
            record["score"] += 1e-12
    cache.write_text("".join(json.dumps(record) + "\n" for record in lines))
    assert cache_reproduce.main(argv) == 1
    result = json.loads(out.read_text())["results"][0]
    assert result["identical"] == 1 and result["records"][1]["identical"] is False
