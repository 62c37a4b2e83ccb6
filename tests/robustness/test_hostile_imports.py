"""Recorded trials as outsiders' tools write them, through ``ltamp import`` and the Python
API (``parse_trials``). Before the fix: a spreadsheet's byte-order mark made the first
column unknown ("missing field 'phase'"), Latin-1 bytes and a CSV field over the csv
module's limit escaped as tracebacks, and a score of 1e300 was imported although training
refuses it."""

from __future__ import annotations

import io
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.trials.importing import parse_trials

HEADER = b"phase,x,y,score,valid,seed\n"
ROW = b"0.3,1.0,0.0,0.5,true,1\n"
BAD = {
    "latin-1 byte": (HEADER + b"0.3,1.0,0.0,0.5,tr\xe9,1\n", "not UTF-8"),
    "field over the csv limit": (HEADER + b"0.3," + b"1" * 200_000 + b",0.0,0.5,true,1\n",
                                 "invalid CSV"),
    "score of 1e300": (HEADER + b"0.3,1.0,0.0,1e300,true,1\n", "beyond"),
}


def _import(source: Path, out: Path) -> tuple[int, list[str]]:
    stdout, stderr = io.StringIO(), io.StringIO()
    with redirect_stdout(stdout), redirect_stderr(stderr), pytest.raises(SystemExit) as done:
        main(["import", str(source), "--skill", "moving2d", "--backend", "synthetic",
              "--out", str(out)])
    return int(done.value.code or 0), stderr.getvalue().strip().splitlines()


@pytest.fixture(scope="module")
def spec():  # type: ignore[no-untyped-def]
    backend = load_backend("synthetic")
    yield backend.skills()["moving2d"]
    backend.close()


@pytest.mark.parametrize("suffix", [".csv", ".jsonl"])
def test_byte_order_mark_is_not_part_of_the_first_name(tmp_path: Path, spec, suffix: str
                                                       ) -> None:  # type: ignore[no-untyped-def]
    source = tmp_path / f"excel{suffix}"
    body = (HEADER + ROW if suffix == ".csv" else
            b'{"phase": 0.3, "x": 1.0, "y": 0.0, "score": 0.5}\n')
    source.write_bytes(b"\xef\xbb\xbf" + body)
    records = parse_trials(source, spec)
    assert len(records) == 1 and records[0].context == (0.3,)
    code, lines = _import(source, tmp_path / "out.jsonl")
    assert code == 0, lines


@pytest.mark.parametrize("label", sorted(BAD))
def test_bad_bytes_are_one_line(tmp_path: Path, spec, label: str) -> None:  # type: ignore[no-untyped-def]
    content, expected = BAD[label]
    source = tmp_path / "recorded.csv"
    source.write_bytes(content)
    with pytest.raises(InputError, match=expected):
        parse_trials(source, spec)
    out = tmp_path / "out.jsonl"
    code, lines = _import(source, out)
    assert code == 2 and len(lines) == 1 and expected in lines[0], lines
    assert str(source) in lines[0]
    assert not out.exists()
