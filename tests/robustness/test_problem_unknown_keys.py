"""Round 4: unknown keys at every level of a YAML problem file are one positioned line.

Held: an unknown top-level key, ``planner`` key or ``world.learned_streams.<s>`` setting,
a duplicate key, a mapping where ``planner.skeleton`` wants a list (``file:line:col`` naming
the field). ``world``'s other fields and ``objects`` names belong to the bindings and the
domain (checked there).

Bugs this file caught (each failed before its fix): top-level ``backend:`` and ``streams:``
keys were accepted by the schema and read by nothing (``backend: box2d`` executed nothing;
that is ``ltamp solve --backend``): now unknown fields like any other; and (in
``planner/problem.py``) a ``world.learned_streams`` entry naming no stream of the stream
file (a misspelt ``sample-good-contrl``) was ignored silently: the bindings look entries up
by stream name, so the misspelt settings never applied and the stream ran with whatever the
bindings do without them (here: refused, "missing the 'sample-good-control' entry", which
names the wrong line).
"""

from __future__ import annotations

import io
import re
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from ltamp_cli.cli.app import main

REPO = Path(__file__).resolve().parents[2]
SOURCE = REPO / "problems/examples/synthetic_goodregion.yaml"


def _variant(tmp: Path, old: str, new: str) -> Path:
    text = SOURCE.read_text().replace("../../domains", str(REPO / "domains"))
    assert old in text
    path = tmp / "problem.yaml"
    path.write_text(text.replace(old, new, 1))
    return path


def _check(path: Path) -> tuple[int, list[str]]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["check", str(path)])
    return int(done.value.code or 0), [line for line in err.getvalue().splitlines() if line]


@pytest.mark.parametrize("old, new, line, words", [
    ("name: synthetic-goodregion", "name: synthetic-goodregion\ncolour: red", 5,
     "unknown field 'colour'"),
    ("  max_time: 30", "  max_time: 30\n  max_tme: 5", 23, "unknown field 'planner.max_tme'"),
    ("      sampler: diverse-lk", "      sampler: diverse-lk\n      samplr: adaptive", 12,
     "unknown field 'world.learned_streams.sample-good-control.samplr'"),
    ("  max_time: 30", "  max_time: 30\n  max_time: 5", 23, "duplicate key 'max_time'"),
    ("  learned_streams:", "  learned_streams:\n    sample-good-contrl: {model: model}", 9,
     "world.learned_streams.sample-good-contrl: the stream file has no stream "
     "'sample-good-contrl' (streams: sample-good-control, test-clear)"),
    ("  learned_streams:", "  learned_streams:\n    test-clear: {model: model}", None,
     None),
    ("name: synthetic-goodregion", "name: synthetic-goodregion\nbackend: box2d", 5,
     "unknown field 'backend'"),
    ("name: synthetic-goodregion", "name: synthetic-goodregion\nstreams: {test-clear: 1}", 5,
     "unknown field 'streams'"),
])
def test_an_unknown_key_is_one_line_with_its_position(tmp_path: Path, old: str, new: str,
                                                      line: int | None,
                                                      words: str | None) -> None:
    code, lines = _check(_variant(tmp_path, old, new))
    if words is None:  # a learned-stream entry for a stream that exists: the bindings' call
        assert code == 0, lines
        return
    assert code == 2, lines
    assert len(lines) == 1, lines
    match = re.match(r"ltamp: error: (.+?):(\d+):(\d+): (.*)", lines[0])
    assert match, lines[0]
    assert match.group(1).endswith("problem.yaml") and int(match.group(2)) == line, lines[0]
    assert words in match.group(4), lines[0]
