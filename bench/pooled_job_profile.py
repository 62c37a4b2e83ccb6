"""Where one pooled experiment job's CPU goes, at ``--full`` size (issue #21).

A job of ``supervised3d`` / ``active3d`` (learner × seed) fits its model at every checkpoint,
predicts F1 on the 1,000 held-out pool trials, and at the θ* checkpoints takes the most
confident valid control among 1,000 candidates for each of 45 held-out contexts (the
pre-check of the ranked candidates) and simulates it (a live trial). This runs one job up to
``--budget`` trials (its θ* checkpoints up to there) twice in one process: with the θ*
pre-check as the experiments now run it (memoised, one control at a time, only as many valid
ones as the model's θ* uses: :func:`bench.paper.poollearn.theta_validity`) and as before
(the baseline: 8 at a time until 3 valid ones, nothing remembered); checks that both give
the same rows, and prints CPU seconds per component (``time.process_time``) and the ratio.
Writes JSON with ``--out``.

    nice -n 5 python bench/pooled_job_profile.py --experiment supervised3d --learner gp \\
        --kernel mlp --budget 50 --out /tmp/profile.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.paper import active3d, supervised3d
from bench.paper.common import REPO, Context, first_valid_lazy, live_score
from bench.paper.poollearn import (
    CheckpointEvaluator,
    memoized_validity,
    pool_curve,
    pooled_skill,
    theta_validity,
)
from bench.paper.pools import SkillBackends
from ltamp_cli.learning import active
from ltamp_cli.learning.active import LearningConfig
from ltamp_cli.learning.metrics import HeldOutSet, SkillEvaluator

EXPERIMENTS = {"supervised3d": (supervised3d, 500), "active3d": (active3d, 700)}


class Meter:
    """CPU seconds and calls per component, for wrapped callables."""

    def __init__(self) -> None:
        self.cpu: dict[str, float] = {}
        self.calls: dict[str, int] = {}

    def wrap(self, name: str, function: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.process_time()
            try:
                return function(*args, **kwargs)
            finally:
                self.cpu[name] = self.cpu.get(name, 0.0) + time.process_time() - start
                self.calls[name] = self.calls.get(name, 0) + 1

        return timed


@contextmanager
def patched(owner: Any, name: str, value: Any) -> Iterator[None]:
    """``owner.name = value`` for the duration (this script's process only)."""
    original = getattr(owner, name)
    setattr(owner, name, value)
    try:
        yield
    finally:
        setattr(owner, name, original)


def profile_job(args: argparse.Namespace, memo: bool) -> dict[str, Any]:
    """Run the job once; CPU seconds per component and its rows."""
    module, score_seed = EXPERIMENTS[args.experiment]
    ctx = Context("full", (REPO / "docs" / "results" / "full").resolve(), False, 1)
    sizes = ctx.sizes(module.SIZES)
    backends = SkillBackends(sizes)
    try:
        backend, pool, spec, contexts, _ = pooled_skill(ctx, sizes, backends, args.skill)
        meter = Meter()

        checked_controls = 0

        def full_test(context: Any, controls: Any) -> Any:
            nonlocal checked_controls
            checked_controls += len(np.atleast_2d(controls))
            return backend.is_valid(args.skill, context, controls)

        checked = meter.wrap("pre-check", full_test)
        # baseline: the pre-check as before issue #21's change (8 controls at a time until 3
        # valid ones, for every learner; nothing remembered)
        is_valid = (theta_validity(memoized_validity(checked), args.learner) if memo
                    else first_valid_lazy(checked))
        success_at = {n for n in sizes["success_at"] if n <= args.budget}
        scorer = live_score(backend, args.skill, score_seed + args.seed)
        evaluator = CheckpointEvaluator(spec, pool.heldout(), scorer, contexts, is_valid,
                                        success_at, args.seed, sizes["candidates"])
        config = LearningConfig(strategy=args.learner, kernel=args.kernel,
                                budget=args.budget, seed=args.seed)
        start = time.process_time()
        with (patched(active, "fit_model", meter.wrap("fit", active.fit_model)),
              patched(HeldOutSet, "f1", meter.wrap("F1 (1,000 test trials)", HeldOutSet.f1)),
              patched(SkillEvaluator, "successes",
                      meter.wrap("θ* total", SkillEvaluator.successes)),
              patched(backend, "run_trial", meter.wrap("live θ* trials", backend.run_trial))):
            rows = pool_curve(pool, spec, config, sizes["eval_every"], evaluator)[0]
        total = time.process_time() - start
    finally:
        backends.close()
    cpu = dict(meter.cpu)
    cpu["θ* argmax (GP/NN, L-BFGS-B)"] = (cpu.get("θ* total", 0.0) - cpu.get("pre-check", 0.0)
                                          - cpu.get("live θ* trials", 0.0))
    return {"memo": memo, "total_cpu_s": round(total, 2), "checked_controls": checked_controls,
            "cpu_s": {k: round(v, 2) for k, v in cpu.items()}, "calls": meter.calls,
            "theta_checkpoints": len(success_at), "rows": rows}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--experiment", choices=sorted(EXPERIMENTS), default="supervised3d")
    parser.add_argument("--skill", default="pour")
    parser.add_argument("--learner", default="gp")
    parser.add_argument("--kernel", default="mlp")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--budget", type=int, default=50)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)
    if args.budget < 1:
        print(f"--budget: expected a positive number of trials, got {args.budget}",
              file=sys.stderr)
        return 2
    runs = [profile_job(args, memo=False), profile_job(args, memo=True)]
    same = runs[0]["rows"] == runs[1]["rows"]
    names = sorted({k for run in runs for k in run["cpu_s"]})
    print(f"{args.experiment} {args.skill} {args.learner}/{args.kernel} seed {args.seed}, "
          f"{args.budget} trials, {runs[0]['theta_checkpoints']} θ* checkpoints; "
          f"load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"{'component':34s} {'baseline s':>11s} {'now s':>11s} {'calls':>13s}")
    for name in names:
        calls = "/".join(str(run["calls"].get(name, "-")) for run in runs)
        print(f"{name:34s} {runs[0]['cpu_s'].get(name, 0.0):11.2f} "
              f"{runs[1]['cpu_s'].get(name, 0.0):11.2f} {calls:>13s}")
    print(f"{'controls pre-checked':34s} {runs[0]['checked_controls']:11d} "
          f"{runs[1]['checked_controls']:11d}")
    ratio = runs[1]["total_cpu_s"] / max(runs[0]["total_cpu_s"], 1e-9)
    print(f"{'job total':34s} {runs[0]['total_cpu_s']:11.2f} {runs[1]['total_cpu_s']:11.2f}"
          f"   now/baseline {ratio:.3f}; rows identical: {same}")
    if args.out is not None:
        args.out.write_text(json.dumps({"args": vars(args) | {"out": str(args.out)},
                                        "load_1min": os.getloadavg()[0], "runs": runs,
                                        "ratio": ratio, "rows_identical": same},
                                       indent=2, default=str) + "\n")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
