"""A model directory read while another writer saves it: every load returns one consistent
model (its metadata and weights from the same save) and none fails.

Before the fix a reader (``ltamp sample``/``evaluate``, a learned stream) that ran while
``ltamp train``/``--refit`` saved the same directory failed with "weights.npz does not match
model.json (a save was interrupted?)" when it read the old model.json and the new weights,
and the digest was checked on one read of weights.npz and the arrays taken from another.
"""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

from ltamp_cli.backends import load_backend
from ltamp_cli.errors import InputError
from ltamp_cli.learning.gp import fit_gp
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.learning.model_dir import load_model, save_model


def test_reads_during_saves_are_whole_models(tmp_path: Path) -> None:
    backend = load_backend("synthetic")
    spec = backend.skills()["moving2d"]
    backend.close()
    rng = np.random.default_rng(0)
    models = []
    for n in (20, 300):  # two fits, told apart by their size
        x = rng.uniform(-1, 1, size=(n, 3))
        models.append(LevelSetModel(spec, fit_gp(x, 0.5 - np.abs(x[:, 0]), restarts=0,
                                                 rng=rng)))
    out = tmp_path / "m"
    save_model(models[0], out, tag=20)
    stop = threading.Event()
    saves = [0]

    def writer() -> None:
        while not stop.is_set():
            model = models[saves[0] % 2]
            save_model(model, out, tag=model.gp.n)
            saves[0] += 1

    thread = threading.Thread(target=writer)
    thread.start()
    failures = []
    reads = 0
    try:
        # At least 40 reads overlapping at least 40 saves, however the threads are scheduled
        # (under load the writer can fall behind the reader).
        while (reads < 40 or saves[0] <= 40) and reads < 20_000:
            reads += 1
            try:
                loaded = load_model(out)
            except InputError as error:
                failures.append(str(error))
                continue
            assert loaded.metadata["tag"] == loaded.metadata["n_train"] == loaded.model.gp.n
    finally:
        stop.set()
        thread.join()
    assert saves[0] > 40 and not failures, f"{len(failures)} of {reads} reads: {failures[:1]}"
