"""Round 5: ``learn_from_pool`` (the Python API) used a trial repeated in its pool twice
(chosen twice, weighing twice in the GP), while ``ltamp train --data`` on the same records
used each once (it dropped repeats while reading the file, with a warning). Now both use
each trial once and warn in one line."""

from __future__ import annotations

import io
import json
import logging
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.cli.app import main
from ltamp_cli.learning.active import LearningConfig, learn_from_pool
from ltamp_cli.trials.record import TrialRecord


def _records() -> list[TrialRecord]:
    rng = np.random.default_rng(5)
    return [TrialRecord("moving2d", (float(rng.uniform(0, 1)),),
                        (float(rng.uniform(0, 4)), float(rng.uniform(-1, 1))),
                        float(rng.normal()), True, 10 + i, "synthetic", index=i)
            for i in range(8)]


def test_api_and_cli_use_a_repeated_trial_once(tmp_path: Path,
                                               caplog: pytest.LogCaptureFixture) -> None:
    records = _records()
    pool = records + records[:3]  # three trials written twice
    backend = load_backend("synthetic")
    try:
        spec = backend.skills()["moving2d"]
    finally:
        backend.close()
    with caplog.at_level(logging.WARNING, logger="ltamp"):
        result = learn_from_pool(spec, pool, LearningConfig(strategy="gp", budget=20, seed=0))
    assert len(result.records) == 8 and result.model.gp.n == 8
    assert any("repeats 3 trial record(s)" in r.getMessage() for r in caplog.records)
    path = tmp_path / "pool.jsonl"
    path.write_text("".join(r.to_json() + "\n" for r in pool))
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["train", "moving2d", "--data", str(path), "--strategy", "gp", "--budget", "20",
              "--out", str(tmp_path / "m")])
    assert done.value.code in (0, None), err.getvalue()
    lines = [line for line in err.getvalue().splitlines() if line]
    assert len(lines) == 1 and "repeats 3 trial record(s)" in lines[0], lines
    saved = json.loads((tmp_path / "m" / "model.json").read_text())
    assert saved["n_train"] == 8
