"""The paper benches live in the repository's ``bench/`` folder, which is not installed: put
the repository root on ``sys.path`` so ``bench.paper`` imports (``python -m bench.paper`` gets
it from the working directory)."""

from __future__ import annotations

import sys
from pathlib import Path

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.insert(0, _ROOT)
