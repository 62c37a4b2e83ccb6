"""Reading a text input file whole, with a size limit.

``Path.read_text`` reads until the end: a problem path that is ``/dev/zero``, a FIFO or a
link to either never ends (``ltamp solve /dev/zero`` grew until MemoryError), and a YAML file
of megabytes takes minutes in PyYAML's pure-Python parser (a 10 MB list: over 3 min). Here at
most ``limit + 1`` bytes are read; a larger input is one :class:`InputError` line.
"""

from __future__ import annotations

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
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise InputError(f"cannot read {what}: {error}", location) from None
    return text.replace("\r\n", "\n").replace("\r", "\n")
