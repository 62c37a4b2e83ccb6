"""Defaults shared by the Python API and the command line (no heavy imports: the CLI reads
them at start-up).

``DEFAULT_STRATEGY`` is both :attr:`ltamp_cli.learning.active.LearningConfig.strategy`'s and
``ltamp train --strategy``'s default. Issue #21 chose it from paired θ* measurements
(``docs/results/learning/README.md``, "GP lengthscale prior").
"""

from __future__ import annotations

DEFAULT_STRATEGY = "lse"
