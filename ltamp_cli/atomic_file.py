"""Output files that are never seen half-written.

A GIF, plot or other output is written to a temporary file beside it and renamed over it
(:func:`replaced_atomically`): a reader sees the old file or the new one, never a torn one;
two writers of one path (two ``ltamp solve --render out.gif``) leave one whole file, the last
one renamed; a writer killed mid-way leaves the old file (and possibly its temporary, a
hidden ``.NAME.<pid>-<thread>.tmp.SUFFIX`` beside it) instead of a truncated one.
"""

from __future__ import annotations

import errno
import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ltamp_cli.errors import InputError

#: errno values of a write that ran out of room (disk full, file size limit, quota).
NO_SPACE = frozenset({errno.ENOSPC, errno.EFBIG, errno.EDQUOT})


@contextmanager
def replaced_atomically(path: str | Path) -> Iterator[Path]:
    """Yield the temporary path to write instead of ``path``; rename it over ``path`` when the
    ``with`` body succeeds, remove it when it fails.

    The temporary keeps ``path``'s suffix (writers that pick a format by suffix still do) and
    is created by the writer itself, so the file mode follows the umask as before. A
    symlink is written through (its target is replaced); an existing output that is not a
    regular file (``/dev/stdout``, a FIFO) is written directly.
    """
    path = Path(path)
    if path.exists() and not path.is_file():
        yield path
        return
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    temporary = target.with_name(f".{target.stem}.{os.getpid()}-{threading.get_ident()}"
                                 f".tmp{target.suffix}")
    try:
        yield temporary
        os.replace(temporary, target)
    except OSError as error:
        if error.errno not in NO_SPACE:
            raise
        # A full disk or a file size limit: one line, the old output kept.
        raise InputError(f"{path}: could not write it ({error.strerror}); "
                         f"{'the old file is kept' if path.exists() else 'nothing written'}"
                         ) from None
    finally:
        temporary.unlink(missing_ok=True)
