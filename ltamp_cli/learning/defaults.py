"""Defaults shared by the Python API and the command line (no heavy imports: the CLI reads
them at start-up).

``DEFAULT_STRATEGY`` is both :attr:`ltamp_cli.learning.active.LearningConfig.strategy`'s and
``ltamp train --strategy``'s default. Issue #21 chose ``lse`` from paired θ* measurements with
the GP's lengthscale prior (``docs/results/learning/README.md``, "GP lengthscale prior"):
over every (skill, seed) unit of the 2D pour and the synthetic ``saturated4d`` and
``narrowing5d`` skills (21 units), ``lse2`` − ``lse`` = −0.19, bootstrap [−0.33, −0.06].
``lse2`` was ahead on the pour alone (+0.08, seed-level interval [+0.004, +0.18]; pass
``--strategy lse2`` there) but failed outright (θ* ≤ 0.2) on 2 of 10 ``saturated4d`` seeds
and all 7 ``narrowing5d`` seeds, where ``lse`` reached 0.98–1.00 and up to 0.6.
"""

from __future__ import annotations

DEFAULT_STRATEGY = "lse"
