"""No text file in the repository keeps a merge's conflict markers (a porting guide once
shipped with both sides of a conflict and the markers between them)."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TEXT_SUFFIXES = {".md", ".py", ".pddl", ".yaml", ".yml", ".toml", ".txt", ".cfg"}
SKIPPED_PARTS = {".git", ".venv", "node_modules", "__pycache__", ".pytest_cache", ".ruff_cache"}


def _text_files() -> list[Path]:
    return [path for path in ROOT.rglob("*")
            if path.suffix in TEXT_SUFFIXES and path.is_file()
            and not SKIPPED_PARTS.intersection(path.relative_to(ROOT).parts)]


def test_no_file_keeps_conflict_markers() -> None:
    found = []
    for path in _text_files():
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            if line.startswith(("<<<<<<< ", ">>>>>>> ")) or line in ("<<<<<<<", ">>>>>>>"):
                found.append(f"{path.relative_to(ROOT)}:{number}")
    assert not found, found
