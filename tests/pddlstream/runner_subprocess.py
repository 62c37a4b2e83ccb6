"""The PDDLStream script runner in a fresh interpreter, for the runner's tests."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def run_runner(args: list[str], cwd: Path, cli: bool = True) -> subprocess.CompletedProcess[str]:
    """``ltamp pddlstream run ARGS`` (``python -m ltamp_cli.pddlstream ARGS`` if not
    ``cli``) in ``cwd``, with ltamp importable and nothing else of this process."""
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "PYTHONPATH": str(REPO),
           "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "XDG_CACHE_HOME": str(cwd / "cache")}
    command = ([sys.executable, "-m", "ltamp_cli", "pddlstream", "run"] if cli
               else [sys.executable, "-m", "ltamp_cli.pddlstream"])
    return subprocess.run([*command, *args], capture_output=True, text=True, timeout=180,
                          cwd=cwd, env=env)
