"""Claims tested, not eyeballed: paired comparisons with bootstrap intervals and exact tests.

Every claim of the paper that the report checks is a comparison of methods run on the same
units (seeds, held-out contexts, planner instances): method A and method B were each scored on
unit ``i``. :func:`paired_comparison` turns the per-unit scores into

* the mean paired difference ``A − B`` with a percentile bootstrap interval over units
  (resampling units with replacement; ``n_boot`` resamples from a fixed seed, so a report is
  reproducible), and
* an exact two-sided sign test on the units where A and B differ (for 0/1 outcomes this is
  McNemar's exact test), which assumes nothing about the distribution of the differences,

and a verdict: **holds** when the whole interval lies above 0 *and* the sign test rejects
"no difference" at ``α = 1 − confidence`` (a bootstrap interval alone is degenerate for a
handful of units: one seed gives a zero-width interval); **does not hold** when B is
significantly better by the same two criteria, or when at least :data:`MIN_UNITS` units put
the whole interval below ``margin`` (A is not better by a practically relevant amount);
**inconclusive** otherwise (too few units to tell). "A is best among several"
(:func:`best_of`) needs every pairwise claim, at a Bonferroni-corrected confidence.

Units are treated as exchangeable: for the Kitchen2D experiment, a unit is one (seed, held-out
context) pair. Written by hand because the few lines needed (paired resampling, a verdict
rule) are not what ``scipy.stats.bootstrap`` offers for a paired, clustered report; the sign
test is scipy's ``binomtest``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.stats import binomtest

Verdict = Literal["holds", "does not hold", "inconclusive"]
#: Units needed before an interval below ``margin`` alone decides "does not hold".
MIN_UNITS = 10


@dataclass(frozen=True)
class Comparison:
    """A paired comparison of method ``a`` against ``b`` on ``n`` shared units.

    ``difference`` is the mean of ``a − b`` over units; ``low``/``high`` its bootstrap interval
    at ``confidence``; ``p_value`` the exact two-sided sign test; ``wins``/``losses`` the units
    where ``a`` scored higher / lower.
    """

    a: str
    b: str
    n: int
    difference: float
    low: float
    high: float
    confidence: float
    p_value: float
    wins: int
    losses: int
    verdict: Verdict

    def describe(self) -> str:
        """One line: ``A − B = +0.12 [+0.04, +0.20] (95 % CI, n = 250, sign test p = 0.003)``."""
        return (f"{self.a} − {self.b} = {self.difference:+.3f} [{self.low:+.3f}, "
                f"{self.high:+.3f}] ({self.confidence:.0%} CI, n = {self.n}, "
                f"{self.wins} wins / {self.losses} losses, sign test p = {self.p_value:.3g})")


def bootstrap_interval(differences: np.ndarray, confidence: float = 0.95,
                       n_boot: int = 10_000, seed: int = 0) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of ``differences (n,)``.

    ``n_boot`` resamples of ``n`` units with replacement from ``default_rng(seed)``; a single
    unit (or all equal) gives a zero-width interval at its value.
    """
    values = np.asarray(differences, dtype=float).reshape(-1)
    if values.size == 0:
        raise ValueError("bootstrap_interval: no units")
    rng = np.random.default_rng(seed)
    # (n_boot, n) indices in chunks keep memory bounded for large unit counts.
    means = np.empty(n_boot)
    chunk = max(1, 2_000_000 // values.size)
    for start in range(0, n_boot, chunk):
        stop = min(n_boot, start + chunk)
        picks = rng.integers(0, values.size, size=(stop - start, values.size))
        means[start:stop] = values[picks].mean(axis=1)
    alpha = 1.0 - confidence
    low, high = np.quantile(means, [alpha / 2.0, 1.0 - alpha / 2.0])
    return float(low), float(high)


def sign_test(differences: np.ndarray) -> tuple[float, int, int]:
    """Exact two-sided sign test of ``differences``: ``(p_value, positives, negatives)``.

    Zero differences (ties) carry no information and are dropped; no non-zero difference
    gives ``p = 1``.
    """
    values = np.asarray(differences, dtype=float).reshape(-1)
    positives, negatives = int(np.sum(values > 0)), int(np.sum(values < 0))
    if positives + negatives == 0:
        return 1.0, 0, 0
    return float(binomtest(positives, positives + negatives, 0.5).pvalue), positives, negatives


#: Largest unit count for which :func:`sign_flip_test` enumerates every sign pattern.
SIGN_FLIP_EXACT_MAX = 16


def sign_flip_test(differences: np.ndarray) -> float:
    """Exact two-sided paired permutation (sign-flip) test of ``differences (n,)``: the share
    of the ``2^n`` sign patterns whose mean is at least as far from 0 as the observed one.

    Unlike :func:`sign_test` it uses the differences' sizes (under "no difference" each
    unit's difference is as likely to have either sign), so a few small losses against
    large wins do not hide an effect; meant for a handful of units (e.g. per-seed mean
    differences). ``n`` above :data:`SIGN_FLIP_EXACT_MAX` raises ``ValueError`` (use the
    unit-level :func:`paired_comparison` there). All zero: ``p = 1``.
    """
    values = np.asarray(differences, dtype=float).reshape(-1)
    if values.size > SIGN_FLIP_EXACT_MAX:
        raise ValueError(f"sign_flip_test: {values.size} units, exact up to "
                         f"{SIGN_FLIP_EXACT_MAX}")
    if values.size == 0 or not np.any(values):
        return 1.0
    # Every sign pattern as a row of ±1 ((2^n, n)), from the bits of 0 .. 2^n − 1.
    bits = (np.arange(2 ** values.size)[:, None] >> np.arange(values.size)) & 1
    means = np.abs(((1 - 2 * bits) * values).mean(axis=1))
    observed = abs(values.mean())
    # A relative tolerance so the observed pattern itself always counts despite rounding.
    return float(np.mean(means >= observed - 1e-12 * max(1.0, observed)))


def paired_comparison(a_name: str, a: Sequence[float] | np.ndarray, b_name: str,
                      b: Sequence[float] | np.ndarray, *, confidence: float = 0.95,
                      margin: float = 0.0, n_boot: int = 10_000, seed: int = 0) -> Comparison:
    """Test the claim "``a`` scores higher than ``b``" on paired units ``a[i]``, ``b[i]``.

    Verdict (module docstring): *holds* if the interval of the mean difference lies above 0
    and the sign test is significant; *does not hold* if ``b`` is significantly better, or if
    ≥ :data:`MIN_UNITS` units put the interval below ``margin`` (``margin ≥ 0``: the smallest
    improvement that would matter, in the scores' units); *inconclusive* otherwise.
    """
    a_values = np.asarray(a, dtype=float).reshape(-1)
    b_values = np.asarray(b, dtype=float).reshape(-1)
    if a_values.shape != b_values.shape:
        raise ValueError(f"paired_comparison: {a_name} has {a_values.size} units, {b_name} "
                         f"{b_values.size}; pairs need the same units")
    keep = np.isfinite(a_values) & np.isfinite(b_values)
    differences = a_values[keep] - b_values[keep]
    if differences.size == 0:
        raise ValueError(f"paired_comparison: no finite pairs for {a_name} vs {b_name}")
    low, high = bootstrap_interval(differences, confidence, n_boot, seed)
    p_value, wins, losses = sign_test(differences)
    significant = p_value < 1.0 - confidence
    verdict: Verdict = "inconclusive"
    if low > 0.0 and significant:
        verdict = "holds"
    elif (high < 0.0 and significant) or (high < margin and differences.size >= MIN_UNITS):
        verdict = "does not hold"
    return Comparison(a_name, b_name, int(differences.size), float(differences.mean()), low,
                      high, confidence, p_value, wins, losses, verdict)


@dataclass(frozen=True)
class Claim:
    """A claim and the comparisons that decide it (all must hold)."""

    text: str
    comparisons: tuple[Comparison, ...]

    @property
    def verdict(self) -> Verdict:
        verdicts = {c.verdict for c in self.comparisons}
        if not verdicts:
            return "inconclusive"
        if "does not hold" in verdicts:
            return "does not hold"
        return "holds" if verdicts == {"holds"} else "inconclusive"

    def describe(self) -> str:
        """``Claim "…": holds — A − B = … ; A − C = …``."""
        verdict = {"holds": "holds", "does not hold": "**does not hold**",
                   "inconclusive": "*inconclusive*"}[self.verdict]
        details = "; ".join(c.describe() for c in self.comparisons) or "no paired data"
        return f"Claim \"{self.text}\": {verdict} — {details}."


def best_of(text: str, best: str, scores: Mapping[str, Sequence[float] | np.ndarray], *,
            confidence: float = 0.95, margin: float = 0.0, seed: int = 0) -> Claim:
    """The claim "``best`` scores higher than every other method in ``scores``".

    ``scores[name]`` are per-unit scores on shared units. The pairwise intervals use the
    Bonferroni-corrected confidence ``1 − (1 − confidence) / (k − 1)`` for ``k`` methods, so
    the claim as a whole keeps ``confidence``.
    """
    others = [name for name in scores if name != best]
    if best not in scores or not others:
        return Claim(text, ())
    level = 1.0 - (1.0 - confidence) / len(others)
    return Claim(text, tuple(
        paired_comparison(best, scores[best], other, scores[other], confidence=level,
                          margin=margin, seed=seed) for other in others))

