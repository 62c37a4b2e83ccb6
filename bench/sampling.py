"""Sampling benchmark: the paper's sampling table (FP, T50, N5, Diversity) on synthetic skills.

For each skill a GP is trained with ``lse2`` (``--budget`` trials, cached in ``--model-dir``
if given), then for ``--runs`` random contexts each sampler (rejection, adaptive, diverse)
draws 50 samples (continuing up to 100 until 5 true positives) from the same set (one β per
run, shared by the samplers). Reported as mean ± std over runs, with the paired difference of
FP between adaptive and rejection (mean ± standard error); T50 is this thread's CPU time
(the machine is shared) with wall time alongside.
Targets: T50 ≤ 0.05 s on ``skill8d`` after 100 trials; adaptive FP ≤ rejection FP (judged on
the paired difference: adaptive must not be worse by more than two standard errors, since both
samplers target the same uniform distribution on ``Â``); diverse Diversity > adaptive
Diversity. Prints a table, writes JSON to ``--out``.

    OMP_NUM_THREADS=1 .venv/bin/python bench/sampling.py [--runs 50] [--skills skill8d,...]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from ltamp_cli.backends import load_backend
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.sampling.factory import make_sampler
from ltamp_cli.sampling.metrics import measure_sampler
from ltamp_cli.sampling.superlevel import build_superlevel_set

SAMPLERS = ("rejection", "adaptive", "diverse")
METRICS = (("fp", "FP (%)", 100.0), ("t50_cpu_s", "T50 CPU (s)", 1.0),
           ("t50_s", "T50 wall (s)", 1.0), ("n5", "N5", 1.0), ("diversity", "Diversity", 1.0))
T50_TARGET_S = 0.05


def trained_model(backend, skill: str, budget: int, cache: Path) -> LevelSetModel:
    directory = cache / f"{skill}_lse2_{budget}"
    if (directory / "model.json").is_file():
        return LevelSetModel.load(str(directory))
    config = LearningConfig(strategy="lse2", budget=budget, init=10, seed=0)
    result = learn_online(backend, skill, config, progress=sys.stderr.isatty())
    assert isinstance(result.model, LevelSetModel)
    result.model.save(str(directory), backend="synthetic", strategy="lse2")
    return result.model


def first_valid_only(validity):
    """``validity`` (``(context, controls (n, dθ)) -> (n,) bool``) evaluated in order only
    until its first ``True``; later controls are reported invalid, unchecked. The first
    ``True`` is the one the full test gives, so a θ* search is unchanged (``None`` stays
    ``None``)."""
    if validity is None:
        return None

    def first_only(context, controls):
        controls = np.atleast_2d(np.asarray(controls, dtype=float))
        result = np.zeros(len(controls), dtype=bool)
        for i in range(len(controls)):
            if bool(np.asarray(validity(context, controls[i : i + 1]), dtype=bool)[0]):
                result[i] = True
                break
        return result

    return first_only


def bench_skill(backend, skill: str, model: LevelSetModel, runs: int, lam: float,
                validate: bool | None = None) -> dict:
    """``validate``: apply ``backend.is_valid`` inside the samplers (default: skill8d only)."""
    spec = model.spec
    validity = None
    if validate or (validate is None and skill == "skill8d"):
        def validity(context, controls):
            return backend.is_valid(skill, context, controls)
    rows: dict[str, list] = {name: [] for name in SAMPLERS}
    for run in tqdm(range(runs), desc=skill, file=sys.stderr, disable=not sys.stderr.isatty()):
        context = backend.sample_context(skill, np.random.default_rng([7, run]))
        # One threshold per run for every sampler: FP depends on β, and β = Φ⁻¹(λ Φ(φ*)) with
        # φ* estimated from random candidates differs from one build to the next; with a
        # shared β the samplers draw from the same set and only their sampling differs.
        # Each sampler still builds its set (θ*, seed members) inside its timed make().
        # Only β is used here, and β depends only on θ* (the first valid control in μ/σ
        # order): test validity until the first valid one of each batch, not the seed
        # members' (on PyBullet ~50 ms each, a quarter of the 3D pour row's validity time).
        beta = build_superlevel_set(model, context, np.random.default_rng([11, run]), lam=lam,
                                    is_valid=first_valid_only(validity)).beta

        def true_score(controls, context=context):
            return backend.true_score(skill, context, controls)

        def to_unit(controls, context=context):
            return model.to_unit(context, controls)[:, : spec.control.dim]

        for index, name in enumerate(SAMPLERS):
            def make(name=name, context=context, index=index, run=run, beta=beta):
                return make_sampler(name, model, context, np.random.default_rng([run, index]),
                                    beta=beta, is_valid=validity, lam=lam)

            rows[name].append(measure_sampler(make, true_score, to_unit))
    table = {}
    for name, results in rows.items():
        table[name] = {}
        for key, _label, factor in METRICS:
            values = np.array([getattr(r, key) for r in results], dtype=float) * factor
            table[name][key] = {"mean": float(values.mean()), "std": float(values.std()),
                                "runs": values.tolist()}  # per run: paired in the report
        table[name]["incomplete_runs"] = sum(r.n_drawn < 50 for r in results)
    # Paired by run (same context, same β): is adaptive's FP lower than rejection's beyond
    # sampling noise? 50 samples per run make FP a coarse binomial estimate.
    difference = np.array([a.fp - r.fp for a, r in zip(rows["adaptive"], rows["rejection"],
                                                        strict=True)]) * 100.0
    table["fp_adaptive_minus_rejection"] = {
        "mean": float(difference.mean()),
        "stderr": float(difference.std(ddof=1) / np.sqrt(len(difference))) if runs > 1 else 0.0,
    }
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=50)
    parser.add_argument("--skills", default="skill8d,moving2d,toy1d")
    parser.add_argument("--budget", type=int, default=100, help="training trials per skill")
    parser.add_argument("--lambda", dest="lam", type=float, default=0.99,
                        help="relaxed β λ (the paper's table uses 0.99)")
    parser.add_argument("--model-dir", type=Path, default=None, help="cache of trained models")
    parser.add_argument("--out", type=Path, default=Path("bench/results/sampling.json"))
    args = parser.parse_args()
    torch.set_num_threads(1)
    backend = load_backend("synthetic")
    results: dict = {"runs": args.runs, "budget": args.budget, "lambda": args.lam, "skills": {}}
    checks: list[tuple[str, bool]] = []
    with tempfile.TemporaryDirectory(prefix="ltamp-bench-sampling-") as scratch:
        cache = args.model_dir or Path(scratch)
        for skill in args.skills.split(","):
            model = trained_model(backend, skill, args.budget, cache)
            table = bench_skill(backend, skill, model, args.runs, args.lam)
            results["skills"][skill] = table
            print(f"\n{skill} ({args.budget} lse2 trials, {args.runs} runs, λ = {args.lam})")
            print(f"{'':>14}" + "".join(f"{name:>22}" for name in SAMPLERS))
            for key, label, _factor in METRICS:
                cells = "".join(
                    f"{table[n][key]['mean']:>12.4g} ± {table[n][key]['std']:<7.3g}"
                    for n in SAMPLERS
                )
                print(f"{label:>14}{cells}")
            fp = {n: table[n]["fp"]["mean"] for n in SAMPLERS}
            div = {n: table[n]["diversity"]["mean"] for n in SAMPLERS}
            paired = table["fp_adaptive_minus_rejection"]
            print(f"{'FP adaptive − rejection (paired)':>14}: {paired['mean']:+.3f} ± "
                  f"{paired['stderr']:.3f} points (mean ± standard error over runs)")
            # Both samplers target the uniform distribution on the same set, so their expected
            # FPs are equal and comparing two sample means is a coin flip: the target holds
            # unless adaptive is worse beyond noise (one-sided, two paired standard errors).
            checks.append((f"{skill}: adaptive FP <= rejection FP within noise (paired "
                           f"difference {paired['mean']:+.3f} ± {paired['stderr']:.3f} points; "
                           f"means {fp['adaptive']:.3f} vs {fp['rejection']:.3f})",
                           paired["mean"] <= 2.0 * paired["stderr"]))
            checks.append((f"{skill}: diverse Diversity > adaptive Diversity",
                           div["diverse"] > div["adaptive"]))
            if skill == "skill8d" and args.budget == 100:
                for name in SAMPLERS:
                    t50 = table[name]["t50_cpu_s"]["mean"]
                    checks.append((f"skill8d: {name} T50 CPU {t50:.4f} s <= {T50_TARGET_S} s",
                                   t50 <= T50_TARGET_S))
    backend.close()
    print()
    for label, ok in checks:
        print(f"{'PASS' if ok else 'FAIL'}  {label}")
    results["checks"] = [{"check": label, "pass": ok} for label, ok in checks]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
