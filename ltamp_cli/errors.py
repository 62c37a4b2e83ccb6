"""User-facing input errors.

Every error caused by bad user input (a malformed PDDL, stream or YAML file, an unknown
name, a bad command-line value) is raised as :class:`InputError`. The CLI prints its
one-line ``str()`` and exits with code 2; no traceback ever reaches the user.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class SourceLocation:
    """A position in a user file; ``line`` and ``column`` are 1-based."""

    path: str
    line: int = 0
    column: int = 0

    def __str__(self) -> str:
        if self.line <= 0:
            return self.path
        return f"{self.path}:{self.line}:{self.column}"


class InputError(Exception):
    """Bad user input, reported as ``file:line:column: message`` on one line."""

    def __init__(self, message: str, location: SourceLocation | None = None) -> None:
        super().__init__(message)
        self.message = " ".join(message.split())
        self.location = location

    def __str__(self) -> str:
        if self.location is None:
            return self.message
        return f"{self.location}: {self.message}"


def location_in(path: str | Path, line: int = 0, column: int = 0) -> SourceLocation:
    return SourceLocation(str(path), line, column)
