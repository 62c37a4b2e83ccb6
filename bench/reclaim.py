"""What freeing a large planner-shaped structure costs, freed at once (``del``) or taken
apart by :class:`ltamp_cli.planner.reclaim.Reclaimer`: CPU seconds, and the longest time
another thread waited for the GIL meanwhile (a thread that sleeps 1 ms in a loop and
records the largest gap between its wake-ups: what the watchdog or the caller would wait).

The structure: a :class:`~ltamp_cli.planner.search.ground.FactIndex` of ``--facts`` binary
facts with one argument index, in an object's attributes (as an optimistic evaluation
holds one), plus a list of small tuples (a grounded task's actions).

    OMP_NUM_THREADS=1 nice -n 5 .venv/bin/python bench/reclaim.py [--facts 1000000]
        [--repeats 3] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import threading
import time
from pathlib import Path
from typing import Any

from ltamp_cli.planner.reclaim import Reclaimer
from ltamp_cli.planner.search.ground import FactIndex

REPO = Path(__file__).resolve().parent.parent
DEFAULT_OUT = REPO / "bench" / "results" / "reclaim.json"


class Holder:
    """Stands for an optimistic evaluation: a fact index and actions as attributes."""

    def __init__(self, facts: int) -> None:
        self.index = FactIndex()
        for number in range(facts):
            self.index.add(("cfree", f"o{number % 1000}", f"p{number}"))
        self.index.lookup("cfree", (0,), ("o1",))  # builds one argument index
        self.actions = [("move", f"p{number}", f"p{number + 1}", float(number))
                        for number in range(facts // 2)]


class GapMonitor:
    """A thread that sleeps 1 ms in a loop and records the longest gap between wake-ups."""

    def __init__(self) -> None:
        self.longest = 0.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        last = time.perf_counter()
        while not self._stop.is_set():
            time.sleep(0.001)
            now = time.perf_counter()
            self.longest = max(self.longest, now - last)
            last = now

    def __enter__(self) -> GapMonitor:
        self._thread.start()
        time.sleep(0.05)
        self.longest = 0.0
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()


def free_at_once(facts: int) -> dict[str, float]:
    holder = Holder(facts)
    with GapMonitor() as monitor:
        cpu, wall = time.process_time(), time.perf_counter()
        del holder
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        time.sleep(0.01)
    return {"cpu_s": cpu, "wall_s": wall, "longest_gil_wait_s": monitor.longest}


def free_in_background(facts: int) -> dict[str, float]:
    holder = Holder(facts)
    reclaimer = Reclaimer()
    with GapMonitor() as monitor:
        cpu, wall = time.process_time(), time.perf_counter()
        reclaimer.give([holder])
        del holder
        reclaimer.start()
        handed = time.perf_counter() - wall
        reclaimer.join()
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    return {"cpu_s": cpu, "wall_s": wall, "longest_gil_wait_s": monitor.longest,
            "hand_over_s": handed}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--facts", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args()
    rows: dict[str, list[dict[str, float]]] = {"del": [], "reclaimer": []}
    for _ in range(args.repeats):  # alternated: both see the same load
        rows["del"].append(free_at_once(args.facts))
        rows["reclaimer"].append(free_in_background(args.facts))
    summary: dict[str, Any] = {
        way: {key: statistics.median(run[key] for run in runs) for key in runs[0]}
        for way, runs in rows.items()}
    print(f"{'way':10s} {'cpu s':>7s} {'wall s':>7s} {'longest GIL wait s':>19s}")
    for way, row in summary.items():
        print(f"{way:10s} {row['cpu_s']:7.3f} {row['wall_s']:7.3f} "
              f"{row['longest_gil_wait_s']:19.4f}")
    print(f"(medians of {args.repeats}; {args.facts} facts; load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"facts": args.facts, "summary": summary, "runs": rows,
                                    "load_average": os.getloadavg()[0],
                                    "cpu_count": os.cpu_count()}, indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
