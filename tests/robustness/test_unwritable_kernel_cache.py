"""Round 4: a ``diverse-lk`` learned stream whose kernel cannot be saved.

Bug this file caught (failed before the fix): with ``XDG_CACHE_HOME`` unwritable (a
read-only or full disk, or a path under a regular file), ``ltamp solve`` of a problem whose
learned stream uses ``diverse-lk`` ended with an ``OSError`` traceback (exit 1) at the
first control the planner reported unusable: ``save_kernel`` ran inside the planner's
feedback. The stream statistics cache already degrades to one warning; the kernel now does
too (learned for this run only), and the solve goes on.
"""

from __future__ import annotations

import io
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from ltamp_cli.cli.app import main

REPO = Path(__file__).resolve().parents[2]


def test_an_unwritable_kernel_cache_is_one_warning(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the cache folder would go\n")
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker))
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["solve", str(REPO / "problems/examples/synthetic_goodregion.yaml"),
              "--no-stats", "--seed", "0"])
    lines = [line for line in err.getvalue().splitlines() if line]
    assert done.value.code == 0, lines
    assert out.getvalue().startswith("status: solved"), out.getvalue()
    assert len(lines) == 1, lines
    assert "cannot save its diversity kernel to " + str(blocker) in lines[0], lines
    assert "learned for this run only" in lines[0]
    assert blocker.read_text() == "a file where the cache folder would go\n"
