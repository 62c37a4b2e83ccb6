"""The shipped domains, problems and models, wherever ltamp is installed.

A wheel carries the repository's ``domains/``, ``problems/`` and ``models/`` folders as package
data under ``ltamp_cli/_shipped/`` (see ``setup.py``); an editable install or a source checkout
uses the folders beside the package. Both keep the three folders side by side, so the
relative paths inside problem files (``domain:``, ``bindings:``, learned-stream models) resolve
the same way.

A *built-in problem name* is a problem file's path below ``problems/`` without ``.yaml``,
e.g. ``kitchen2d/coffee``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

from ltamp_cli.errors import InputError

SHIPPED_FOLDERS = ("domains", "problems", "models")
PACKAGED_FOLDER = "_shipped"
_SUMMARY_LINE = re.compile(r"^#\s?(.*)$")


def shipped_root() -> Path:
    """The folder holding ``domains/``, ``problems/`` and ``models/``.

    The package's own copy (an installed wheel) first, else the checkout the package was
    imported from. Raises :class:`InputError` when neither exists.
    """
    packaged = files("ltamp_cli") / PACKAGED_FOLDER
    if isinstance(packaged, Path) and (packaged / "problems").is_dir():
        return packaged
    checkout = Path(__file__).resolve().parent.parent
    if (checkout / "problems").is_dir() and (checkout / "domains").is_dir():
        return checkout
    raise InputError("the shipped domains and problems are not installed with this ltamp "
                     "(reinstall it from a wheel or a full clone)")


@dataclass(frozen=True)
class BuiltinProblem:
    """A shipped problem: its built-in ``name``, file ``path`` and first comment line."""

    name: str
    path: Path
    summary: str


def builtin_problems() -> dict[str, BuiltinProblem]:
    """Every shipped problem by built-in name (``group/name``), sorted by name."""
    problems_dir = shipped_root() / "problems"
    found: dict[str, BuiltinProblem] = {}
    for path in sorted(problems_dir.rglob("*.yaml")):
        name = path.relative_to(problems_dir).with_suffix("").as_posix()
        found[name] = BuiltinProblem(name, path, _summary(path))
    return found


def _summary(path: Path) -> str:
    """The first sentence of the comment block a problem file starts with ('' if none)."""
    words: list[str] = []
    with path.open(encoding="utf-8") as handle:
        for line in handle:
            match = _SUMMARY_LINE.match(line.strip())
            if match is None:
                break
            words.extend(match.group(1).split())
    text = " ".join(words)
    end = text.find(". ")
    return text if end < 0 else text[:end + 1]


def resolve_problem_path(argument: str | Path) -> Path:
    """An existing file as given; else the shipped problem named ``argument`` (with or
    without ``.yaml``, with or without a leading ``problems/``); else ``argument`` unchanged
    (so that loading it reports the missing file)."""
    path = Path(argument)
    if path.exists():
        return path
    name = path.as_posix().removesuffix(".yaml").removeprefix("problems/")
    if not name or path.is_absolute() or ".." in path.parts:
        return path
    try:
        candidate = shipped_root() / "problems" / f"{name}.yaml"
    except InputError:
        return path
    return candidate if candidate.is_file() else path


__all__ = ["BuiltinProblem", "builtin_problems", "resolve_problem_path", "shipped_root"]
