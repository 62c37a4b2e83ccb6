"""``pending.json`` (ask/tell) is data like the rest of a model directory: a crafted or
damaged one is one error line and nothing is recorded; a score the refit cannot use is
refused before anything is written. Before the fix: a proposal naming other context keys
raised KeyError, a string value ValueError, a control of 1e300 CholeskyError, and
'ltamp tell --score 1e300' on an honest pending trial appended the trial and then failed
saving the model (ValueError: NaN), tracebacks all; duplicate names or bounds of ±1e308 in
its spec were accepted."""

from __future__ import annotations

import io
import json
from collections.abc import Callable
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig
from ltamp_cli.learning.ask_tell import ask, tell


def _proposal(**fields: Any) -> Callable[[dict[str, Any]], None]:
    return lambda data: data["proposal"].update(fields)


def _spec_control(**fields: Any) -> Callable[[dict[str, Any]], None]:
    return lambda data: data["spec"]["control"].update(fields)


HOSTILE: dict[str, Callable[[dict[str, Any]], None]] = {
    "context names another parameter": _proposal(context={"other": 0.3}),
    "context value is a string": _proposal(context={"phase": "abc"}),
    "control far outside the box": _proposal(control={"x": 1e300, "y": 0.0}),
    "seed is a string": _proposal(seed="5"),
    "negative index": _proposal(index=-7),
    "another skill": _proposal(skill="pour"),
    "duplicate names in the spec": _spec_control(names=["x", "x"]),
    "bounds of +-1e308 in the spec": _spec_control(lows=[-1e308, -1e308],
                                                   highs=[1e308, 1e308]),
}


@pytest.fixture
def asked(tmp_path: Path) -> Path:
    backend = load_backend("synthetic")
    try:
        ask(backend, "moving2d", LearningConfig(seed=0), tmp_path / "m")
    finally:
        backend.close()
    return tmp_path / "m"


def _tell_cli(directory: Path, score: str) -> tuple[int, list[str]]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["tell", str(directory), "--score", score])
    return int(done.value.code or 0), err.getvalue().strip().splitlines()


@pytest.mark.parametrize("label", sorted(HOSTILE))
def test_crafted_pending_trial_is_one_line(asked: Path, label: str) -> None:
    path = asked / "pending.json"
    data = json.loads(path.read_text())
    HOSTILE[label](data)
    path.write_text(json.dumps(data))
    with pytest.raises(InputError, match="corrupt pending trial"):
        tell(asked, 0.5)
    code, lines = _tell_cli(asked, "0.5")
    assert code == 2 and len(lines) == 1 and "corrupt pending trial" in lines[0], lines
    assert not (asked / "trials.jsonl").exists()


def test_score_beyond_the_limit_records_nothing(asked: Path) -> None:
    code, lines = _tell_cli(asked, "1e300")
    assert code == 2 and len(lines) == 1 and "beyond" in lines[0], lines
    assert (asked / "pending.json").exists() and not (asked / "trials.jsonl").exists()
    code, lines = _tell_cli(asked, "0.5")  # the honest answer still goes through
    assert code == 0, lines
    assert len((asked / "trials.jsonl").read_text().splitlines()) == 1
