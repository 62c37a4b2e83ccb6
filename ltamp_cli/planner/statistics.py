"""Stream statistics that persist across planner runs, one JSON file per domain.

They record, per stream, how often it was called, how often it produced something and the
time it took, accumulated over every run that was given the same ``statistics_dir`` (the CLI
uses the user cache directory, never the current one). ``p_success`` and ``overhead`` are
what PDDLStream calls a stream's learned effort.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ltamp_cli.planner.streams import StreamStats


def default_statistics_dir() -> Path:
    """``$XDG_CACHE_HOME/ltamp/stream-statistics`` (``~/.cache`` when unset)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "ltamp" / "stream-statistics"


@dataclass
class StreamStatistics:
    path: Path | None
    totals: dict[str, dict[str, float]] = field(default_factory=dict)

    @staticmethod
    def load(directory: str | os.PathLike[str] | None, domain: str) -> StreamStatistics:
        if directory is None:
            return StreamStatistics(None)
        path = Path(directory) / f"{domain}.json"
        try:
            totals = json.loads(path.read_text())["streams"]
        except (OSError, ValueError, KeyError, TypeError):
            totals = {}  # missing or unreadable history: start afresh, never fail a plan
        return StreamStatistics(path, {str(k): dict(v) for k, v in totals.items()})

    def update(self, run: Mapping[str, StreamStats]) -> None:
        for name, stats in run.items():
            total = self.totals.setdefault(name, {"calls": 0, "successes": 0, "time_s": 0.0})
            # Histories written before CPU time was kept: their wall time bounds it from above.
            total.setdefault("cpu_s", total["time_s"])
            total["calls"] += stats.calls
            total["successes"] += stats.successes
            total["time_s"] += stats.time_s
            total["cpu_s"] += stats.cpu_s

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

    def save(self) -> None:
        """Write atomically (temporary file + rename) so concurrent runs never tear it."""
        if self.path is None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        payload: dict[str, Any] = {"version": 1, "streams": self.totals}
        handle, temporary = tempfile.mkstemp(dir=self.path.parent, suffix=".tmp")
        with os.fdopen(handle, "w") as stream:
            json.dump(payload, stream, indent=1, sort_keys=True)
        os.replace(temporary, self.path)
