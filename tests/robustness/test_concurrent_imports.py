"""Two imports of one recording into one trial file at the same time add every trial once.

``import`` skips trials the file already holds ("a re-run adds nothing"), but it read the
file and appended without the writer lock ``collect``/``train`` hold: two imports started
together both found the file empty and both appended every row (2 x 3000 lines). Now the
lock is held from the read to the append: the second import waits for nothing, it is
refused in one line (or, if it comes after, adds nothing).
"""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

from ltamp_cli.backends import load_backend
from ltamp_cli.errors import InputError
from ltamp_cli.trials.importing import import_file
from ltamp_cli.trials.record import TrialDataset

ROWS = 3000


def test_two_imports_at_once_add_each_trial_once(tmp_path: Path) -> None:
    backend = load_backend("synthetic")
    spec = backend.skills()["moving2d"]
    backend.close()
    rng = np.random.default_rng(0)
    lines = ["phase,x,y,score"] + [
        f"{p:.6f},{x:.6f},{y:.6f},{s:.6f}" for p, x, y, s in zip(
            rng.uniform(0, 1, ROWS), rng.uniform(0, 4, ROWS), rng.uniform(-1, 1, ROWS),
            rng.uniform(-1, 1, ROWS), strict=True)]
    source = tmp_path / "recorded.csv"
    source.write_text("\n".join(lines) + "\n")
    out = tmp_path / "trials.jsonl"
    start = threading.Barrier(2)
    outcomes: list[object] = []

    def run() -> None:
        start.wait()
        try:
            outcomes.append(import_file(source, spec, out).added)
        except InputError as error:
            outcomes.append(error)

    threads = [threading.Thread(target=run) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=300)
    added = sorted(o for o in outcomes if isinstance(o, int))
    refused = [o for o in outcomes if isinstance(o, InputError)]
    assert added in ([ROWS], [0, ROWS]) and len(added) + len(refused) == 2, outcomes
    assert all("being written by another" in str(error) for error in refused)
    assert len(TrialDataset(out).read()) == ROWS
