"""One writer at a time for trial files and model directories.

``collect`` (a ``.jsonl`` file), ``train`` and ``tell`` (a model directory) hold an exclusive
lock on their output while they run. A second writer of the same output either fails at once
with one :class:`~ltamp_cli.errors.InputError` line (exit 2) or, with ``wait=True``
(``--wait``), blocks until the first one is done. The lock is an OS file lock (``filelock``):
it is released by the kernel when its holder dies, so a killed writer never blocks later runs.
The lock belongs to the resolved path, so a symlink to an output shares the output's lock;
a trial file's writer also holds an OS lock on the file itself (its device and inode), so a
hard link to an output, whatever its name or folder, finds the output's writer too. (A model
directory cannot be hard-linked; its lock file lives inside it.) A trial file that does not
exist yet is created empty when its lock is taken, so that a hard link made to it while it is
written is recognised; it is removed again if the writer leaves it empty.
"""

from __future__ import annotations

import errno
import fcntl
import functools
import os
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
        # The file a symlink names (even a dangling one): ``O_EXCL`` refuses to create
        # through a symlink, and releasing must remove the created file, not the link.
        target = output.resolve()
        identity = None if is_directory else _lock_identity(target, wait, option)
        try:
            yield
        finally:
            if identity is not None:
                _release_identity(target, *identity)
    finally:
        lock.release()


def _lock_identity(output: Path, wait: bool, option: str) -> tuple[int, bool]:
    """Lock the file ``output`` itself (``flock``: one lock per device and inode, whatever
    the name it is opened by), creating it empty if it does not exist. Returns the open
    descriptor that holds the lock and whether it was created."""
    created = False
    try:
        try:
            fd = os.open(output, os.O_RDONLY | os.O_NONBLOCK)
        except FileNotFoundError:
            fd = os.open(output, os.O_RDONLY | os.O_NONBLOCK | os.O_CREAT | os.O_EXCL, 0o644)
            created = True
    except OSError as error:
        raise InputError(f"{option}: cannot write {output}: {error.strerror or error}") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
    except OSError as error:
        os.close(fd)
        if error.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
            raise InputError(f"{option}: {output} is being written by another ltamp process "
                             "(collect/train/tell), under another name (a hard link); wait "
                             "for it to finish or pass --wait") from None
        raise InputError(f"{option}: cannot lock {output}: {error.strerror or error}") from None
    return fd, created


def _release_identity(output: Path, fd: int, created: bool) -> None:
    """Undo :func:`_lock_identity`: remove the file if it was created and is still empty."""
    try:
        if created and os.fstat(fd).st_size == 0:
            try:
                if os.path.samestat(os.stat(output), os.fstat(fd)):
                    os.unlink(output)
            except OSError:
                pass
    finally:
        os.close(fd)


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
