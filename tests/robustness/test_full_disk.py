"""Round 4: writing trials, models and plots when the disk is full.

Simulated with a file size limit (``RLIMIT_FSIZE``, what ``ulimit -f`` sets): a write past
it fails with ``EFBIG`` after writing what fits, as a full disk fails with ``ENOSPC``
(Python ignores ``SIGXFSZ``).

Bugs this file caught (each failed before its fix, one commit):

* ``collect`` ended with an ``OSError: short write`` traceback (exit 1) and left the
  half-written record at the end of the file;
* ``train`` (saving the model) ended with ``OSError: [Errno 27] File too large`` (exit 1)
  and left ``weights.npz.<pid>-<thread>.tmp`` in the model directory;
* ``sample --plot`` (and every output written through ``atomic_file``) ended with a
  traceback.

Now each is one line (exit 2) naming the file and the reason; the trial file holds whole
records only (a rerun without the limit resumes to every index once), the model directory
and an existing output are unchanged.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def _ltamp(args: list[str], cwd: Path, limit: int | None = None) -> tuple[int, list[str]]:
    def limited() -> None:
        if limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1",
           "XDG_CACHE_HOME": str(cwd / "cache"), "MPLCONFIGDIR": str(cwd / "mpl")}
    done = subprocess.run([sys.executable, "-m", "ltamp_cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600, preexec_fn=limited)
    lines = [line for line in done.stderr.splitlines()
             if line and "matplotlib" not in line]  # its font cache cannot be saved either
    return done.returncode, lines


def _one_error(code: int, lines: list[str], *words: str) -> None:
    assert code == 2, (code, lines)
    assert len(lines) == 1 and lines[0].startswith("ltamp: error: "), lines
    assert all(word in lines[0] for word in words), lines[0]


def test_collect_on_a_full_disk_leaves_whole_records_and_resumes(tmp_path: Path) -> None:
    out = tmp_path / "trials.jsonl"
    args = ["collect", "toy1d", "-n", "300", "--backend", "synthetic", "--out", str(out)]
    code, lines = _ltamp(args, tmp_path, limit=20_000)
    _one_error(code, lines, str(out), "could not append", "the file is unchanged")
    data = out.read_bytes()
    assert data.endswith(b"\n") and len(data) <= 20_000
    kept = [json.loads(line) for line in data.splitlines()]
    assert 50 < len(kept) < 300
    code, lines = _ltamp(args, tmp_path)
    assert code == 0, lines
    indices = [json.loads(line)["index"] for line in out.read_bytes().splitlines()]
    assert sorted(indices) == list(range(300))


def test_a_model_that_cannot_be_saved_leaves_the_directory_unchanged(tmp_path: Path) -> None:
    pool = tmp_path / "pool.jsonl"
    code, lines = _ltamp(["collect", "toy1d", "-n", "250", "--backend", "synthetic",
                          "--out", str(pool)], tmp_path)
    assert code == 0, lines
    model = tmp_path / "model"
    train = ["train", "toy1d", "--backend", "synthetic", "--data", str(pool), "--out",
             str(model)]
    code, lines = _ltamp([*train, "--budget", "20", "--init", "20"], tmp_path)
    assert code == 0, lines
    before = {p.name: p.read_bytes() for p in model.iterdir()}
    # 200 training points make weights.npz larger than 2 kB; the 20-point one is smaller
    code, lines = _ltamp([*train, "--budget", "200", "--init", "200"], tmp_path, limit=2048)
    _one_error(code, lines, str(model), "could not save the model", "unchanged")
    assert {p.name: p.read_bytes() for p in model.iterdir()} == before
    code, lines = _ltamp(["sample", str(model), "-n", "3"], tmp_path)
    assert code == 0, lines


def test_a_plot_that_cannot_be_written_is_one_line(tmp_path: Path) -> None:
    pool = tmp_path / "pool.jsonl"
    _ltamp(["collect", "toy1d", "-n", "40", "--backend", "synthetic", "--out", str(pool)],
           tmp_path)
    model = tmp_path / "model"
    code, lines = _ltamp(["train", "toy1d", "--backend", "synthetic", "--data", str(pool),
                          "--out", str(model), "--budget", "20", "--init", "20"], tmp_path)
    assert code == 0, lines
    plot = tmp_path / "samples.png"
    plot.write_bytes(b"old")
    code, lines = _ltamp(["sample", str(model), "-n", "5", "--plot", str(plot)], tmp_path,
                         limit=2048)
    _one_error(code, lines, str(plot), "could not write it", "the old file is kept")
    assert plot.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".samples")) == []
