"""Round 3: a trial file whose last line lacks its newline (written by another tool, or
saved by an editor) but holds a whole record. It was taken for a line torn by a crash:
``read`` skipped it (``train --data`` learned from one trial fewer, without a word) and the
next ``append`` (``collect``/``train``/``tell`` resuming the file) *deleted* it. Now a last
line that is one complete, valid record is read, and ``append`` ends it with its newline;
a really torn line (not a whole record) is still skipped and cut."""

from __future__ import annotations

import json
from pathlib import Path

from ltamp_cli.trials.record import TrialDataset, TrialRecord


def record(index: int, score: float) -> TrialRecord:
    return TrialRecord("moving2d", (0.5,), (0.25, 0.75), score, True, index, "synthetic",
                       index=index)


def write_without_final_newline(path: Path, records: list[TrialRecord]) -> None:
    path.write_text("\n".join(r.to_json() for r in records))


def test_last_whole_record_without_newline_is_read(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    write_without_final_newline(path, [record(0, 0.1), record(1, 0.2), record(2, 0.3)])
    assert [r.score for r in TrialDataset(path).read()] == [0.1, 0.2, 0.3]


def test_append_keeps_the_last_whole_record(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    write_without_final_newline(path, [record(0, 0.1), record(1, 0.2), record(2, 0.3)])
    TrialDataset(path).append(record(3, 0.4))
    lines = path.read_bytes().split(b"\n")
    assert lines[-1] == b"" and len(lines) == 5
    assert [json.loads(line)["score"] for line in lines[:-1]] == [0.1, 0.2, 0.3, 0.4]
    assert TrialDataset(path).done_indices() == {0, 1, 2, 3}


def test_crlf_file_without_final_newline(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    path.write_bytes((record(0, 0.1).to_json() + "\r\n" + record(1, 0.2).to_json()).encode())
    assert [r.index for r in TrialDataset(path).read()] == [0, 1]
    TrialDataset(path).append(record(2, 0.3))
    assert [r.index for r in TrialDataset(path).read()] == [0, 1, 2]


def test_a_torn_line_is_still_skipped_and_cut(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    whole = record(0, 0.1).to_json() + "\n"
    for torn in (record(1, 0.2).to_json()[:-1], '{"skill": "moving2d"}', "[1, 2]", "{"):
        path.write_text(whole + torn)
        assert [r.index for r in TrialDataset(path).read()] == [0]
        TrialDataset(path).append(record(2, 0.3))
        assert path.read_text() == whole + record(2, 0.3).to_json() + "\n"
