"""Every ``python`` block of docs/porting-from-pddlstream.md runs, in order, in one
namespace (later blocks use earlier names); the blocks' own asserts check the results."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

PAGE = Path(__file__).resolve().parents[2] / "docs" / "porting-from-pddlstream.md"
FENCE = re.compile(r"^```(\S*)")


def python_blocks(path: Path) -> list[tuple[int, str]]:
    """(first line number, code) of each fenced ``python`` block."""
    blocks: list[tuple[int, str]] = []
    language: str | None = None
    start = 0
    body: list[str] = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        fence = FENCE.match(line)
        if fence and language is None:
            language, start, body = fence.group(1), number + 1, []
        elif fence:
            if language == "python":
                blocks.append((start, "\n".join(body) + "\n"))
            language = None
        elif language is not None:
            body.append(line)
    return blocks


def test_page_has_snippets() -> None:
    assert len(python_blocks(PAGE)) >= 4


def test_every_snippet_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                            capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "porting_doc"}
    for line, code in python_blocks(PAGE):
        # Pad with blank lines so that tracebacks point at the page's own line numbers.
        exec(compile("\n" * (line - 1) + code, str(PAGE), "exec"), namespace)
    assert "Solved: True" in capsys.readouterr().out
    assert list(tmp_path.iterdir()) == []  # nothing written into the working directory
