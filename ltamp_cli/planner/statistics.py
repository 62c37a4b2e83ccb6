"""Stream statistics that persist across planner runs, one JSON file per domain.

They record, per stream, how often it was called, how often it produced something and the
time it took, accumulated over every run that was given the same ``statistics_dir`` (the CLI
uses the user cache directory, never the current one). ``p_success`` and ``overhead`` are
what PDDLStream calls a stream's learned effort.

The cache never costs a plan and never leaves its directory:

* the file name is the domain name reduced to safe characters plus a digest of the full name,
  so a domain called ``../../x`` or ``/etc/x`` still lands inside ``statistics_dir``;
* a corrupt or unreadable file is one warning (logger ``ltamp``) and is replaced on save;
* a failed write (read-only or full disk) is one warning, and no temporary file is left;
* concurrent runs merge: :meth:`StreamStatistics.save` adds only this run's counts to what
  is on disk, under a file lock, so no run's calls are lost.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import re
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from filelock import FileLock, Timeout

from ltamp_cli.planner.streams import StreamStats

LOGGER = logging.getLogger("ltamp")
FIELDS = ("calls", "successes", "time_s", "cpu_s")
LOCK_TIMEOUT_S = 30.0
_UNSAFE = re.compile(r"[^A-Za-z0-9_-]+")


def default_statistics_dir() -> Path:
    """``$XDG_CACHE_HOME/ltamp/stream-statistics`` (``~/.cache`` when unset)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "ltamp" / "stream-statistics"


def statistics_file_name(domain: str) -> str:
    """``<safe part of domain>-<16 hex digest of domain>.json``: never a path, ≤ 90 bytes."""
    safe = _UNSAFE.sub("_", domain).strip("_")[:64] or "domain"
    digest = hashlib.sha256(domain.encode("utf-8", "surrogatepass")).hexdigest()[:16]
    return f"{safe}-{digest}.json"


def _warn(message: str) -> None:
    LOGGER.warning("ltamp: warning: %s", " ".join(message.split()))


def _read_totals(path: Path) -> tuple[dict[str, dict[str, float]], str | None]:
    """Totals on disk and, when the file exists but cannot be used, why."""
    try:
        text = path.read_text(encoding="utf-8")
    except (FileNotFoundError, NotADirectoryError):
        return {}, None  # no history yet (save() reports a cache that cannot be created)
    except (OSError, UnicodeDecodeError) as error:
        return {}, f"cannot read {error}"
    try:
        streams = json.loads(text)["streams"]
        if not isinstance(streams, dict):
            raise TypeError("'streams' is not an object")
        totals = {str(name): _checked_total(total) for name, total in streams.items()}
    except (ValueError, KeyError, TypeError, RecursionError) as error:
        return {}, f"corrupt ({type(error).__name__}: {error})"
    return totals, None


def _checked_total(total: Any) -> dict[str, float]:
    if not isinstance(total, dict):
        raise TypeError("a stream's totals are not an object")
    checked: dict[str, float] = {}
    for key in FIELDS:
        if key not in total:
            continue
        value = total[key]
        if isinstance(value, bool) or not isinstance(value, int | float) \
                or not math.isfinite(value) or value < 0:
            raise ValueError(f"{key} = {value!r} is not a finite count or time")
        checked[key] = value
    checked.setdefault("calls", 0)
    checked.setdefault("successes", 0)
    checked.setdefault("time_s", 0.0)
    return checked


def _add(into: dict[str, dict[str, float]], name: str, stats: Mapping[str, float]) -> None:
    total = into.setdefault(name, {"calls": 0, "successes": 0, "time_s": 0.0})
    # Histories written before CPU time was kept: their wall time bounds it from above.
    total.setdefault("cpu_s", total["time_s"])
    for key in FIELDS:
        total[key] += stats.get(key, 0.0 if key != "cpu_s" else stats.get("time_s", 0.0))


@dataclass
class StreamStatistics:
    path: Path | None
    totals: dict[str, dict[str, float]] = field(default_factory=dict)
    # This run's counts only: what save() adds to the file, whatever other runs wrote since.
    run: dict[str, dict[str, float]] = field(default_factory=dict)
    problem_on_load: str | None = None

    @staticmethod
    def load(directory: str | os.PathLike[str] | None, domain: str) -> StreamStatistics:
        """The history of ``domain`` in ``directory`` (``None``: keep nothing)."""
        if directory is None:
            return StreamStatistics(None)
        path = Path(directory) / statistics_file_name(domain)
        totals, problem = _read_totals(path)
        if problem is not None:
            _warn(f"stream statistics {path} {problem}: starting afresh (the file will be "
                  "replaced)")
        return StreamStatistics(path, totals, problem_on_load=problem)

    def update(self, run: Mapping[str, StreamStats]) -> None:
        for name, stats in run.items():
            counts = {"calls": stats.calls, "successes": stats.successes,
                      "time_s": stats.time_s, "cpu_s": stats.cpu_s}
            _add(self.totals, name, counts)
            _add(self.run, name, counts)

    def summary(self) -> dict[str, dict[str, float]]:
        return {
            name: {
                "calls": total["calls"],
                "p_success": round(total["successes"] / total["calls"], 4)
                if total["calls"] else None,
                "overhead_s": round(total["time_s"] / total["calls"], 6)
                if total["calls"] else None,
            }
            for name, total in sorted(self.totals.items())
        }

    def save(self) -> bool:
        """Add this run's counts to the file under a lock; ``False`` (and one warning) when
        the cache could not be written — the caller's plan is never affected."""
        if self.path is None:
            return True
        temporary: str | None = None
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            with FileLock(str(self.path) + ".lock", timeout=LOCK_TIMEOUT_S):
                merged, problem = _read_totals(self.path)
                if problem is not None and problem != self.problem_on_load:
                    _warn(f"stream statistics {self.path} {problem}: replacing it")
                for name, counts in self.run.items():
                    _add(merged, name, counts)
                payload: dict[str, Any] = {"version": 1, "streams": merged}
                handle, temporary = tempfile.mkstemp(dir=self.path.parent, suffix=".tmp")
                with os.fdopen(handle, "w") as stream:
                    json.dump(payload, stream, indent=1, sort_keys=True)
                os.replace(temporary, self.path)
                temporary = None
            self.totals = merged
            return True
        except (OSError, Timeout) as error:
            _warn(f"stream statistics not saved to {self.path.parent}: {error}")
            return False
        finally:
            if temporary is not None:
                Path(temporary).unlink(missing_ok=True)
