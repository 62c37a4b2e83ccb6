"""One writer at a time for trial files and model directories.

``collect`` (a ``.jsonl`` file), ``train`` and ``tell`` (a model directory) hold an exclusive
lock on their output while they run. A second writer of the same output either fails at once
with one :class:`~ltamp_cli.errors.InputError` line (exit 2) or, with ``wait=True``
(``--wait``), blocks until the first one is done. The lock is an OS file lock (``filelock``):
it is released by the kernel when its holder dies, so a killed writer never blocks later runs.
The lock belongs to the resolved path, so a symlink to an output shares the output's lock
(hard links are not recognised).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from filelock import FileLock, Timeout

from ltamp_cli.errors import InputError

DIRECTORY_LOCK = ".ltamp-writer.lock"


def lock_path(output: Path, is_directory: bool) -> Path:
    """The lock file of ``output``: inside a directory, or beside a file (``.NAME.lock``)."""
    if is_directory:
        return output / DIRECTORY_LOCK
    return output.with_name(f".{output.name}.lock")


@contextmanager
def exclusive_writer(output: str | Path, *, is_directory: bool, wait: bool = False,
                     option: str = "--out") -> Iterator[None]:
    """Hold the writer lock of ``output`` for the ``with`` body.

    Raises :class:`InputError` if another process holds it and ``wait`` is false, or if the
    lock file cannot be created (an unwritable output).
    """
    output = Path(output)
    try:
        # The lock of the file itself, however it is named: a symlink (or ``dir/../x``) to
        # an output another writer holds must find that writer's lock, not a new one.
        path = lock_path(output.resolve(), is_directory)
        path.parent.mkdir(parents=True, exist_ok=True)
        lock = FileLock(str(path), timeout=-1 if wait else 0)
        lock.acquire()
    except Timeout:
        raise InputError(f"{option}: {output} is being written by another ltamp process "
                         "(collect/train/tell); wait for it to finish or pass --wait") from None
    except OSError as error:
        raise InputError(f"{option}: cannot write {output}: {error.strerror or error}") from None
    try:
        yield
    finally:
        lock.release()


def holds_writer_lock(option: str, *, is_directory: bool
                      ) -> Callable[[Callable[..., None]], Callable[..., None]]:
    """Decorate a command whose keyword ``option`` names its output and which takes ``wait``:
    the command runs holding :func:`exclusive_writer` on that output."""

    def decorate(command: Callable[..., None]) -> Callable[..., None]:
        @functools.wraps(command)
        def locked(**arguments: object) -> None:
            output = arguments[option]
            with exclusive_writer(Path(str(output)), is_directory=is_directory,
                                  wait=bool(arguments.get("wait", False)),
                                  option="--" + option.replace("_", "-")):
                command(**arguments)

        return locked

    return decorate
