"""Round 5: an input path that is no regular file said "no such file" whatever it was (a
directory, a symbolic-link loop, a dangling link, /dev/null), and a gzip-compressed trial
file (a pool archive, ``*.jsonl.gz``) was "not a trial record (UnicodeDecodeError ...)".
Now each says what the path is, in one line, through the CLI and the Python API."""

from __future__ import annotations

import gzip
import io
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.trials.importing import read_rows
from ltamp_cli.trials.record import TrialDataset, TrialRecord


def _cli(*argv: str) -> tuple[int, list[str]]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(list(argv))
    return int(done.value.code or 0), [line for line in err.getvalue().splitlines() if line]


def _paths(tmp: Path) -> dict[str, tuple[Path, str]]:
    (tmp / "folder.jsonl").mkdir()
    (tmp / "loop_a.jsonl").symlink_to(tmp / "loop_b.jsonl")
    (tmp / "loop_b.jsonl").symlink_to(tmp / "loop_a.jsonl")
    (tmp / "dangling.jsonl").symlink_to(tmp / "nowhere.jsonl")
    return {"directory": (tmp / "folder.jsonl", "is a directory, expected a file"),
            "link loop": (tmp / "loop_a.jsonl", "is a symbolic-link loop"),
            "dangling link": (tmp / "dangling.jsonl", "is a dangling symbolic link"),
            "missing": (tmp / "missing.jsonl", "no such file"),
            "device": (Path("/dev/null"), "is not a regular file")}


@pytest.mark.parametrize("kind", ["directory", "link loop", "dangling link", "missing",
                                  "device"])
def test_an_input_that_is_no_file_says_what_it_is(tmp_path: Path, kind: str) -> None:
    path, words = _paths(tmp_path)[kind]
    for argv in (["train", "moving2d", "--data", str(path), "--out", str(tmp_path / "m")],
                 ["import", str(path), "--skill", "moving2d", "--out",
                  str(tmp_path / "t.jsonl")]):
        code, lines = _cli(*argv)
        assert code == 2 and len(lines) == 1 and words in lines[0], (argv, lines)
    with pytest.raises(InputError, match=words):
        list(read_rows(path))


def test_a_gzip_trial_file_is_named_as_such(tmp_path: Path) -> None:
    record = TrialRecord("moving2d", (0.5,), (1.0, 0.0), 0.1, True, 1, "synthetic", index=0)
    path = tmp_path / "pool.jsonl.gz"
    path.write_bytes(gzip.compress((record.to_json() + "\n").encode()))
    with pytest.raises(InputError, match="gzip-compressed") as error:
        TrialDataset(path).read()
    assert str(error.value).startswith(f"{path}:1:1: ")
    code, lines = _cli("train", "moving2d", "--data", str(path), "--out", str(tmp_path / "m"))
    assert code == 2 and len(lines) == 1 and "gunzip" in lines[0], lines
