"""The paper's sampling metrics (table "Effectiveness of adaptive and diverse sampling").

For one sampler run on a skill with a known true score:

* **FP** — share of the first 50 samples whose true score is ``≤ 0``;
* **T50** — seconds to produce those 50 samples (building the set and ``β`` included);
* **N5** — samples needed to get 5 true positives, drawing at most 100 (100 if never reached);
* **Diversity** — ``D(S) = log det(Ξ/ζ² + I)`` of those (up to) 5 positives with the
  unit-lengthscale SE kernel, ``ζ = 0.1``, in normalised control coordinates.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from ltamp_cli.sampling.kernel_learning import diversity

FP_SAMPLES = 50
N_POSITIVES = 5
MAX_SAMPLES = 100

# physical controls (k, dθ) -> true scores (k,)
TrueScore = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class SamplingRun:
    """Metrics of one run. ``t50_s``: wall seconds, ``t50_cpu_s``: this thread's CPU seconds.

    ``n_drawn`` is how many samples the sampler produced (fewer than 50 if it stopped);
    ``positives`` how many of the (up to 5) positives the diversity was measured on.
    """

    fp: float
    t50_s: float
    t50_cpu_s: float
    n5: int
    diversity: float
    n_drawn: int
    positives: int


def false_positive_rate(true_scores: np.ndarray) -> float:
    """Share of samples with true score ``≤ 0`` (``nan`` for no samples)."""
    true_scores = np.asarray(true_scores, dtype=float)
    return float(np.mean(true_scores <= 0.0)) if len(true_scores) else float("nan")


def samples_to_positives(true_scores: np.ndarray, count: int = N_POSITIVES,
                         cap: int = MAX_SAMPLES) -> int:
    """Samples needed until ``count`` have true score ``> 0`` (``cap`` if never)."""
    hits = np.flatnonzero(np.asarray(true_scores, dtype=float)[:cap] > 0.0)
    return int(hits[count - 1]) + 1 if len(hits) >= count else cap


def measure_sampler(
    make: Callable[[], Iterator[np.ndarray]],
    true_score: TrueScore,
    to_unit: Callable[[np.ndarray], np.ndarray],
) -> SamplingRun:
    """Run ``make()`` (sampler construction is timed) and compute the four metrics.

    ``to_unit`` maps physical controls ``(k, dθ)`` to normalised ones for the diversity.
    """
    wall, cpu = time.perf_counter(), time.thread_time()
    sampler = make()
    drawn: list[np.ndarray] = []
    for control in sampler:
        drawn.append(control)
        if len(drawn) == FP_SAMPLES:
            break
    t50, t50_cpu = time.perf_counter() - wall, time.thread_time() - cpu
    scores = list(true_score(np.array(drawn))) if drawn else []
    # Keep drawing (up to 100 in all) only if the first 50 hold fewer than 5 positives.
    while sum(s > 0 for s in scores) < N_POSITIVES and len(drawn) < MAX_SAMPLES:
        control = next(sampler, None)
        if control is None:
            break
        drawn.append(control)
        scores.append(float(true_score(control[None, :])[0]))
    scores_array = np.asarray(scores, dtype=float)
    positives = np.flatnonzero(scores_array > 0.0)[:N_POSITIVES]
    unit = to_unit(np.array(drawn)[positives]) if len(positives) else np.empty((0, 0))
    return SamplingRun(
        fp=false_positive_rate(scores_array[:FP_SAMPLES]),
        t50_s=t50,
        t50_cpu_s=t50_cpu,
        n5=samples_to_positives(scores_array),
        diversity=diversity(unit) if len(positives) else 0.0,
        n_drawn=len(drawn),
        positives=len(positives),
    )
