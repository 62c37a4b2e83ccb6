"""Hostile inputs through real ``ltamp`` subprocesses, each with a time limit.

The fixed corpus (:mod:`hostile_corpus`) covers deep nesting, long names, hostile model
directories, corrupt and unwritable caches; random mutations of the shipped files are solved
in subprocesses with a new seed every run (printed on failure; set ``LTAMP_FUZZ_SEED`` to
replay); concurrent writers of one trial file must neither fail badly nor duplicate trials.
"""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from hostile_corpus import CORPUS, HostileCase, run_case, solve_mutation
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import seed as hypothesis_seed
from hypothesis import strategies as st
from ltamp_fuzz import PDDL_TARGETS, REPO, YAML_TARGETS, mutated_text, sandbox

FUZZ_SEED = int(os.environ.get("LTAMP_FUZZ_SEED", random.SystemRandom().randrange(2**32)))
CASE_TIMEOUT_S = 120.0


@pytest.fixture(scope="module")
def root() -> Iterator[Path]:
    with sandbox() as path:
        yield path


@pytest.mark.parametrize("case", CORPUS, ids=[case.name for case in CORPUS])
def test_hostile_corpus(root: Path, case: HostileCase) -> None:
    with tempfile.TemporaryDirectory(dir=root) as workdir:
        outcome, why = run_case(case, Path(workdir), root / "domains", CASE_TIMEOUT_S)
    assert why is None, (why, outcome)


def test_random_mutations_solved_in_subprocesses(root: Path) -> None:
    """Six new mutations each run, through `solve` (the in-process tests run `check`)."""
    findings: list[object] = []

    @hypothesis_seed(FUZZ_SEED)
    @settings(max_examples=6, deadline=None, database=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @given(data=st.data())
    def case(data: st.DataObject) -> None:
        target = data.draw(st.sampled_from(PDDL_TARGETS + YAML_TARGETS))
        text = data.draw(mutated_text((root / target.file).read_text()))
        outcome, why = solve_mutation(root, target.file, target.problem, text, CASE_TIMEOUT_S)
        if why is not None:
            findings.append((why, target.file, outcome))

    case()
    assert not findings, f"LTAMP_FUZZ_SEED={FUZZ_SEED}: {findings}"


def test_concurrent_collects_on_one_file_lose_and_duplicate_nothing(tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(REPO), "XDG_CACHE_HOME": str(tmp_path / "cache")}
    command = [sys.executable, "-m", "ltamp_cli", "collect", "moving2d", "--backend",
               "synthetic", "-n", "3000", "--out", "t.jsonl"]
    writers = [subprocess.Popen(command, cwd=tmp_path, env=env, stderr=subprocess.PIPE,
                                text=True) for _ in range(4)]
    results = [(w.wait(timeout=300), w.stderr.read()) for w in writers]
    assert all(code in (0, 2) and "Traceback" not in err for code, err in results), results
    assert any(code == 0 for code, _ in results)
    indices = [json.loads(line)["index"]
               for line in (tmp_path / "t.jsonl").read_text().splitlines()]
    assert sorted(indices) == list(range(3000))
