"""Checks of the file options of the commands, done before any work starts.

An output that cannot be written (a parent that is a file, a name component over the
file-system limit, a read-only folder) or an input file that does not exist is one
:class:`~ltamp_cli.errors.InputError` line naming the option, instead of a traceback after
minutes of training or sampling.
"""

from __future__ import annotations

import os
from pathlib import Path

from ltamp_cli.errors import InputError
from ltamp_cli.textfile import not_a_file


def _component_problem(path: Path) -> str | None:
    limit = 255
    for part in path.parts:
        if len(os.fsencode(part)) > limit:
            return f"a name component is longer than {limit} bytes"
    return None


def writable_output_file(path: Path, option: str) -> Path:
    """Check that ``path`` could be created or replaced as a file; creates nothing."""
    problem = _component_problem(path)
    if problem is not None:
        raise InputError(f"{option}: cannot write {str(path)[:120]!r}: {problem}")
    if path.is_dir():
        raise InputError(f"{option}: {path} is a directory, expected a file name")
    ancestor = path.absolute().parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        if ancestor.is_symlink():  # a dangling link: nothing can be created through it
            break
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise InputError(f"{option}: cannot write {path}: {ancestor} is not a folder")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise InputError(f"{option}: cannot write {path}: folder {ancestor} is not writable")
    return path


def existing_input_file(path: Path, option: str) -> Path:
    """Check that ``path`` is an existing, readable file."""
    problem = _component_problem(path)
    if problem is not None:
        raise InputError(f"{option}: {str(path)[:120]!r}: {problem}")
    if not path.is_file():
        raise InputError(f"{option}: {not_a_file(path)}")
    if not os.access(path, os.R_OK):
        raise InputError(f"{option}: {path} is not readable")
    return path
