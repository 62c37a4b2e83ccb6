"""Round 4: ``collect`` into a file that another process truncates (or rotates) meanwhile.

Bug this file caught (failed before the fix): ``collect`` appended every trial and then
printed "400 new trials; OUT now holds trials 0..399" although the file had been emptied
mid-run and held only the trials appended after that. It now reads the file again: one
warning line saying how many trials are missing and that a rerun fills them, and ``--json``
reports ``missing``. A rerun then fills exactly the missing indices.
"""

from __future__ import annotations

import io
import json
import os
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ltamp_cli.backends.protocol import ParamSpace, SkillSpec, TrialResult
from ltamp_cli.cli.app import main


class Rotated:
    """One 1-D skill whose 50th trial empties the output file, as a log rotation would."""

    name = "rotated"

    def __init__(self, out: Path) -> None:
        self.out = out
        self.calls = 0
        self.spec = SkillSpec("tilt", ParamSpace(("w",), (0.0,), (1.0,)),
                              ParamSpace(("a",), (-1.0,), (1.0,)))

    def skills(self) -> dict[str, SkillSpec]:
        return {"tilt": self.spec}

    def sample_context(self, skill: str, rng: np.random.Generator) -> np.ndarray:
        return self.spec.context.sample_uniform(rng, 1)[0]

    def is_valid(self, skill: str, context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return np.ones(len(np.atleast_2d(controls)), dtype=bool)

    def run_trial(self, skill: str, context: np.ndarray, control: np.ndarray,
                  seed: int) -> TrialResult:
        self.calls += 1
        if self.calls == 50:
            os.truncate(self.out, 0)  # another process: `: > out`
        return TrialResult(0.3 - abs(float(control[0])), True)

    def close(self) -> None:
        pass


def _collect(out: Path, *extra: str) -> tuple[int, str, list[str]]:
    stdout, stderr = io.StringIO(), io.StringIO()
    with redirect_stdout(stdout), redirect_stderr(stderr), pytest.raises(SystemExit) as done:
        main(["collect", "tilt", "-n", "200", "--backend", "rotated", "--out", str(out),
              *extra])
    return (int(done.value.code or 0), stdout.getvalue(),
            [line for line in stderr.getvalue().splitlines() if line])


def test_a_file_emptied_meanwhile_is_reported_and_refilled(tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch
                                                           ) -> None:
    import ltamp_cli.trials.collect as collect_module

    out = tmp_path / "trials.jsonl"
    original = collect_module.load_backend

    def load_backend(name: str, **options: Any) -> Any:
        return Rotated(out) if name == "rotated" else original(name, **options)

    monkeypatch.setattr(collect_module, "load_backend", load_backend)
    code, stdout, lines = _collect(out, "--json")
    assert code == 0, lines
    report = json.loads(stdout)
    held = len(out.read_bytes().splitlines())
    assert report["added"] == 200 and report["missing"] == 200 - held > 0, (report, held)
    assert len(lines) == 1 and lines[0].startswith(f"ltamp: warning: {out} lacks "), lines
    assert "run the same command again" in lines[0]
    code, _stdout, lines = _collect(out)  # the backend's calls restart: truncates again
    assert code == 0
    code, _stdout, lines = _collect(out)
    indices = sorted(json.loads(line)["index"] for line in out.read_bytes().splitlines())
    assert indices == list(range(200)), lines
    assert lines == [f"0 new trials; {out} now holds trials 0..199"]
