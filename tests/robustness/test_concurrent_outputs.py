"""Outputs (GIFs, plots) are never seen half-written, whoever writes them at the same time.

Before the fix ``write_animation`` (``ltamp solve --render out.gif``) and the plots
(``sample --plot``, ``plot level-set/curves --out``) wrote straight into the output: a
reader (a viewer, a second ``solve`` of the same path) saw a truncated GIF while it was
written, and two writers of one path could interleave. Now each writes a temporary file
beside the output and renames it over (:mod:`ltamp_cli.atomic_file`).
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ltamp_cli.backends.frames import write_animation

REPO = Path(__file__).resolve().parents[2]
N_FRAMES = 30


def _frames(seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.integers(0, 255, size=(160, 160, 3), dtype=np.uint8) for _ in range(N_FRAMES)]


def _write(path: Path, seed: int) -> None:
    write_animation(_frames(seed), [i * 0.1 for i in range(N_FRAMES)], [f"w{seed}"] * N_FRAMES,
                    path)


def _whole_gif_frames(path: Path) -> int:
    """The GIF's frame count, after decoding its last frame (a torn file fails here)."""
    with Image.open(path) as image:
        count = int(image.n_frames)
        image.seek(count - 1)
        image.load()
        return count


def test_a_gif_is_never_read_half_written(tmp_path: Path) -> None:
    path = tmp_path / "out.gif"
    _write(path, 0)
    expected = _whole_gif_frames(path)
    assert expected > 5
    enough_reads = threading.Event()

    def keep_writing(seed: int) -> None:
        # Write until the reader has looked often enough: a loaded CI machine may let the
        # reader run only a few times during a fixed number of writes.
        writes = 0
        while writes < 3 or not enough_reads.is_set():
            _write(path, seed)
            writes += 1

    writers = [threading.Thread(target=keep_writing, args=(seed,)) for seed in (1, 2)]
    for writer in writers:
        writer.start()
    torn = reads = 0
    while any(writer.is_alive() for writer in writers):
        try:
            frames = _whole_gif_frames(path)
        except Exception:  # a torn file fails in many ways (EOF, bad header, "bomb")
            frames = -1
        reads += 1
        torn += frames != expected
        if reads >= 20:
            enough_reads.set()
    for writer in writers:
        writer.join()
    assert reads >= 20 and torn == 0, f"{torn} of {reads} reads saw a torn GIF"
    assert _whole_gif_frames(path) == expected
    assert [p.name for p in tmp_path.iterdir()] == ["out.gif"]  # no temporary left


def test_a_failed_write_keeps_the_old_output(tmp_path: Path) -> None:
    path = tmp_path / "out.gif"
    _write(path, 0)
    before = path.read_bytes()
    with pytest.raises(ValueError):
        write_animation([np.zeros((4, 4, 3), np.uint8), "not a frame"], [0.0, 0.1], ["", ""],
                        path)  # type: ignore[list-item]
    assert path.read_bytes() == before and [p.name for p in tmp_path.iterdir()] == ["out.gif"]


def test_a_symlinked_output_is_written_through(tmp_path: Path) -> None:
    (tmp_path / "real").mkdir()
    link = tmp_path / "link.gif"
    link.symlink_to(tmp_path / "real" / "out.gif")
    _write(link, 0)
    assert link.is_symlink() and (tmp_path / "real" / "out.gif").stat().st_size > 0


@pytest.mark.slow
def test_two_sample_plots_to_one_path(tmp_path: Path) -> None:
    model = REPO / "domains" / "synthetic_goodregion" / "model"
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
    runs = [subprocess.Popen([sys.executable, "-m", "ltamp_cli", "sample", str(model),
                              "--context", f"phase={phase}", "-n", "20", "--plot", "s.png"],
                             cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True) for phase in (0.2, 0.7)]
    for run in runs:
        _out, err = run.communicate(timeout=300)
        assert run.returncode == 0, err[-800:]
    with Image.open(tmp_path / "s.png") as image:
        image.load()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.png"]
