"""``world.learned_streams`` settings take the limits of ``ltamp sample``'s options: a
lambda outside [0.95, 0.999] or a NaN/inf beta is one error line naming the field. Before
the fix ``lambda: 0.5`` and ``beta: .nan`` were accepted (the CLI refuses both; the YAML
schema only bounds lambda by 1)."""

from __future__ import annotations

import io
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from ltamp_cli.cli.app import main

REPO = Path(__file__).resolve().parents[2]
PROBLEM = REPO / "problems" / "examples" / "synthetic_goodregion.yaml"


@pytest.mark.parametrize("setting, expected", [
    ("lambda: 0.5", "lambda: expected a value in"),
    ("lambda: 0.9999", "lambda: expected a value in"),
    ("beta: .nan", "beta: expected a finite number"),
    ("beta: -.inf", "beta: expected a finite number"),
])
def test_bad_setting_is_one_line(tmp_path: Path, setting: str, expected: str) -> None:
    text = PROBLEM.read_text().replace("../../domains", str(REPO / "domains"))
    text = text.replace("      sampler: diverse-lk\n",
                        f"      sampler: diverse-lk\n      {setting}\n")
    assert setting in text
    path = tmp_path / "problem.yaml"
    path.write_text(text)
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["check", str(path)])
    lines = err.getvalue().strip().splitlines()
    assert done.value.code == 2 and len(lines) == 1, lines
    assert "world.learned_streams.sample-good-control." + expected in lines[0], lines
