"""Checks of command-line options shared by several commands."""

from __future__ import annotations

import math

from ltamp_cli.errors import InputError


def check_confidence_options(lam: float, beta: float | None) -> None:
    """``--lambda`` within the relaxed-β range and ``--beta`` finite, else exit 2."""
    from ltamp_cli.learning.confidence import LAMBDA_RANGE  # lazy: keeps CLI start-up light

    if not LAMBDA_RANGE[0] <= lam <= LAMBDA_RANGE[1]:
        raise InputError(f"--lambda: expected a value in [{LAMBDA_RANGE[0]}, "
                         f"{LAMBDA_RANGE[1]}], got {lam}")
    if beta is not None and not math.isfinite(beta):
        raise InputError(f"--beta: expected a finite number, got {beta}")
