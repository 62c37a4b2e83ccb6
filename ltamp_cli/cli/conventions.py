"""What every command shares: log level, progress on stderr and ``--json`` output.

The root options (``-v``/``-q``) become a :class:`CliSettings` that sets the level of Python
logging (to stderr) once per invocation; progress follows that level (``-q`` hides it).
"""

from __future__ import annotations

import json
import logging
import sys
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import typer

LOG_FORMAT = "ltamp: %(levelname)s: %(name)s: %(message)s"
TICK_S = 0.5


@dataclass(frozen=True)
class CliSettings:
    """``verbosity``: -1 quiet (errors only), 0 warnings, 1 info, 2 or more debug."""

    verbosity: int = 0

    @property
    def log_level(self) -> int:
        if self.verbosity < 0:
            return logging.ERROR
        return (logging.WARNING, logging.INFO)[self.verbosity] if self.verbosity < 2 \
            else logging.DEBUG


def configure_logging(settings: CliSettings) -> None:
    """Send ltamp's log records (and warnings) to stderr at the settings' level."""
    logging.basicConfig(stream=sys.stderr, format=LOG_FORMAT, level=settings.log_level,
                        force=True)
    logging.captureWarnings(True)


def progress_enabled() -> bool:
    """Progress is drawn on stderr only on a terminal, and never with ``-q`` (which lowers
    logging to errors only)."""
    return sys.stderr.isatty() and logging.getLogger("ltamp").isEnabledFor(logging.WARNING)


def emit(payload: Mapping[str, Any], as_json: bool,
         human: Callable[[Mapping[str, Any]], list[str]] | None = None) -> None:
    """Print a command's result: one JSON object with ``--json``, else human lines (by
    default ``key: value`` per entry)."""
    if as_json:
        typer.echo(json.dumps(payload))
        return
    lines = human(payload) if human is not None else [
        f"{key}: {_human_value(value)}" for key, value in payload.items()]
    for line in lines:
        typer.echo(line)


def _human_value(value: Any) -> str:
    """Floats to 3 decimals, mappings as ``name=value ...``, the rest as ``str``."""
    if isinstance(value, float):
        return f"{value:.3f}"
    if isinstance(value, Mapping):
        return "  ".join(f"{key}={_human_value(item)}" for key, item in value.items())
    if isinstance(value, list | tuple) and value and all(isinstance(v, float) for v in value):
        return "[" + ", ".join(f"{v:.3f}" for v in value) + "]"
    return str(value)


@contextmanager
def progress_line(label: str) -> Iterator[None]:
    """While the block runs, show ``label … N s`` on stderr (TTY only, not with ``-q``), then
    clear the line. For steps that report no finer progress (a solve, an execution)."""
    if not progress_enabled():
        yield
        return
    done = threading.Event()
    start = time.perf_counter()

    def draw() -> None:
        sys.stderr.write(f"\r{label} … {time.perf_counter() - start:.0f} s\x1b[K")
        sys.stderr.flush()

    def tick() -> None:
        while not done.wait(TICK_S):
            draw()

    # Drawn once up front, so a step shorter than a tick still says what it was doing.
    draw()

    ticker = threading.Thread(target=tick, name="ltamp-progress", daemon=True)
    ticker.start()
    try:
        yield
    finally:
        done.set()
        ticker.join()
        sys.stderr.write("\r\x1b[K")
        sys.stderr.flush()
