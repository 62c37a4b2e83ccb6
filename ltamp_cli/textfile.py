"""Reading a text input file whole, with a size limit.

``Path.read_text`` reads until the end: a problem path that is ``/dev/zero``, a FIFO or a
link to either never ends (``ltamp solve /dev/zero`` grew until MemoryError), and a YAML file
of megabytes takes minutes in PyYAML's pure-Python parser (a 10 MB list: over 3 min). Here at
most ``limit + 1`` bytes are read; a larger input is one :class:`InputError` line.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

from ltamp_cli.errors import InputError, SourceLocation

#: Largest YAML problem file read (bytes). The shipped ones are under 3 KB; PyYAML parses
#: about 0.1 MB of dense YAML per CPU second on this machine's cores.
MAX_YAML_BYTES = 1 << 20
#: Largest PDDL file read (bytes): large generated problems stay well below.
MAX_PDDL_BYTES = 64 << 20


def read_limited_text(path: str | Path, limit: int, what: str) -> str:
    """The UTF-8 text of ``path`` with newlines normalised as ``Path.read_text`` does
    (``\\r\\n`` and ``\\r`` become ``\\n``); ``InputError`` when it is missing, unreadable,
    not UTF-8 or longer than ``limit`` bytes."""
    location = SourceLocation(str(path))
    try:
        with open(path, "rb") as stream:
            data = stream.read(limit + 1)
    except FileNotFoundError:
        raise InputError(f"{what} not found", location) from None
    except OSError as error:
        raise InputError(f"cannot read {what}: {error}", location) from None
    if len(data) > limit:
        raise InputError(f"{what} is larger than {limit / (1 << 20):g} MB: ltamp reads "
                         f"{what}s of at most {limit} bytes", location)
    return decoded_text(data, str(path), what).replace("\r\n", "\n").replace("\r", "\n")


# Byte-order marks of the encodings a text editor saves "Unicode" text in (Windows Notepad:
# UTF-16 LE with a BOM). YAML itself allows UTF-16 and UTF-32 files that start with one.
_BOMS = ((b"\x00\x00\xfe\xff", "utf-32-be"), (b"\xff\xfe\x00\x00", "utf-32-le"),
         (b"\xfe\xff", "utf-16-be"), (b"\xff\xfe", "utf-16-le"))


def decoded_text(data: bytes, path: str, what: str) -> str:
    """``data`` decoded: UTF-8 (a UTF-8 byte-order mark is kept for the parsers, which skip
    it), or UTF-16/UTF-32 when a byte-order mark says so. Other bytes are one
    :class:`InputError` at the line and column of the first byte that is not UTF-8."""
    for bom, encoding in _BOMS:
        if data.startswith(bom):
            try:
                return data[len(bom):].decode(encoding)
            except UnicodeDecodeError as error:
                raise InputError(f"cannot read {what}: it starts with a {encoding} byte-order "
                                 f"mark but is not {encoding} text ({error.reason})",
                                 SourceLocation(path)) from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        start = error.start
        line = data.count(b"\n", 0, start) + 1
        column = start - (data.rfind(b"\n", 0, start) + 1) + 1
        raise InputError(f"cannot read {what}: byte 0x{data[start]:02x} is not UTF-8 text "
                         "(save the file as UTF-8)", SourceLocation(path, line, column)) from None


def not_a_file(path: str | Path) -> str:
    """Why ``path`` is no readable regular file, as the words of an error line: a directory,
    a symbolic-link loop or a dangling link read better than the "no such file" that
    ``Path.is_file()`` alone suggests."""
    path = Path(path)
    try:
        os.stat(path)
    except OSError as error:
        if error.errno == errno.ELOOP:
            return f"{path} is a symbolic-link loop"
        if path.is_symlink():
            return f"{path} is a dangling symbolic link"
        if error.errno == errno.ENOENT:
            return f"no such file {path}"
        return f"{path}: {error.strerror or error}"
    if path.is_dir():
        return f"{path} is a directory, expected a file"
    if not path.is_file():
        return f"{path} is not a regular file"
    return f"{path} is not readable" if not os.access(path, os.R_OK) else f"{path} is a file"
