"""The package's imports point one way (the design card): the CLI may import everything;
learned streams build on learning, sampling and the planner; backends never import the CLI;
the planner knows nothing of skills, learning or physics.

Read with ``ast`` (nothing is imported), so a forbidden import fails here even when it sits
inside a function.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "ltamp_cli"

#: folder -> the ltamp_cli folders it must not import.
FORBIDDEN: dict[str, set[str]] = {
    "backends": {"cli", "learned_streams", "learning", "sampling", "pddlstream"},
    "planner": {"cli", "learned_streams", "learning", "sampling", "backends", "trials",
                "pddlstream"},
    "learning": {"cli", "learned_streams", "sampling", "planner", "pddlstream"},
    "sampling": {"cli", "learned_streams", "planner", "pddlstream"},
    "trials": {"cli", "learned_streams", "learning", "sampling", "planner"},
    "learned_streams": {"cli"},
    "pddlstream": {"cli", "learned_streams", "learning", "sampling", "backends"},
}


def imported_folders(path: Path) -> dict[str, int]:
    """The ``ltamp_cli`` sub-packages/modules ``path`` imports, each with a line number."""
    found: dict[str, int] = {}
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        names: list[str] = []
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
            if node.module == "ltamp_cli":
                names = [f"ltamp_cli.{alias.name}" for alias in node.names]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        for name in names:
            parts = name.split(".")
            if parts[0] == "ltamp_cli" and len(parts) > 1:
                found.setdefault(parts[1], node.lineno)
    return found


def violations(folder: str) -> list[str]:
    out = []
    for path in sorted((PACKAGE / folder).rglob("*.py")):
        for target, line in imported_folders(path).items():
            if target in FORBIDDEN[folder]:
                out.append(f"{path.relative_to(PACKAGE.parent)}:{line} imports ltamp_cli.{target}")
    return out


@pytest.mark.parametrize("folder", sorted(FORBIDDEN))
def test_imports_point_one_way(folder: str) -> None:
    assert (PACKAGE / folder).is_dir()
    assert violations(folder) == []


def test_the_check_sees_a_forbidden_import(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text("def f():\n    from ltamp_cli.cli.app import app\n"
                      "    import ltamp_cli.planner\n")
    assert imported_folders(module) == {"cli": 2, "planner": 3}
