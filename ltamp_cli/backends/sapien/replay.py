"""The CPU replay renderer used when SAPIEN has no render device.

It lives in :mod:`ltamp_cli.backends.pybullet.replay` (the PyBullet executor renders its
executions the same way); this module keeps the SAPIEN-side name.
"""

from __future__ import annotations

from ltamp_cli.backends.pybullet.replay import (
    KIND_RGBA,
    BeadGroup,
    ReplayFrame,
    ReplayRecorder,
    ReplayRenderer,
    ReplayScene,
    render_replay,
)

__all__ = [
    "KIND_RGBA",
    "BeadGroup",
    "ReplayFrame",
    "ReplayRecorder",
    "ReplayRenderer",
    "ReplayScene",
    "render_replay",
]
