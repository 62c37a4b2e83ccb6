"""Checks of command-line options shared by several commands."""

from __future__ import annotations

from ltamp_cli.errors import InputError


def check_confidence_options(lam: float, beta: float | None) -> None:
    """``--lambda`` within the relaxed-β range and ``--beta`` finite, else exit 2."""
    from ltamp_cli.learning.confidence import confidence_problem  # lazy: light start-up

    problem = confidence_problem(lam, beta)
    if problem is not None:
        raise InputError(f"--{problem[0]}: {problem[1]}")
