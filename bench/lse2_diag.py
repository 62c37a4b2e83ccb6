"""Per-trial diagnostics of an active learner's choices (issue #21: GP-LSE2 on the 2D pour).

``python -m bench.lse2_diag --skill pour --strategy lse2 --seed 0 --trials 60 --out FILE``
runs the online learning loop of :func:`ltamp_cli.learning.active.learn_online` step by step
(same proposals, same seeds) and writes one JSON line per trial to ``FILE``: the trial index,
whether the acquisition chose it (``active``), the drawn context and chosen control (physical
and normalised), the GP's ``μ``/``σ`` (score units) at the choice *before* the trial, whether
the control lies on the box boundary (some normalised coordinate with ``|u| > 0.95``), whether
it passes the pre-check, the true score and the GP hyperparameters. A summary (successes,
boundary share of active choices, mean σ/|μ|) is printed at the end. ``--skill saturated4d``
(or ``narrowing5d``) runs ``bench.lse2``'s synthetic skill instead of Box2D. ``--prior-sd``
sets ``LearningConfig.lengthscale_prior_sd`` (``none``: maximum marginal likelihood, the fit
before issue #21's prior); ``--no-uniform-if-classified`` turns off ``lse2``'s uniform choice
when ψ ≤ 0 for every candidate (then a chosen ``psi <= 0`` means every candidate had ψ ≤ 0;
with the fallback on it marks a fallback choice). ``python -m bench.lse2_diag show FILE [K]``
prints the logged hyperparameters every K trials (:func:`show`).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.sanity import run_trial_safely
from ltamp_cli.learning.active import LearningConfig, _Learner, _propose, _trial_seed, goes_active
from ltamp_cli.learning.baselines import RandomModel
from ltamp_cli.learning.model import LevelSetModel

BOUNDARY = 0.95


def show(path: Path, every: int) -> None:
    """Print the hyperparameters a diagnostics file logged, every ``every`` trials and at each
    success: lengthscales (normalised units), outputscale σ_f² and constant mean (score units),
    whether the prior straddle can see the level (1.96 σ_f > |mean|) and ψ at the choice."""
    successes = 0
    print(f"{'trial':>5} {'succ':>4} {'lengthscales':34} {'σ_f²':>6} {'mean':>6} "
          f"{'1.96σ_f':>7} {'ψ':>6} score")
    for line in path.read_text().splitlines():
        row = json.loads(line)
        shown = "lengthscales" in row and (row["index"] % every == 0 or row["score"] > 0)
        if shown:
            reach = 1.96 * float(row["outputscale"]) ** 0.5
            print(f"{row['index']:5d} {successes:4d} {row['lengthscales']!s:34} "
                  f"{row['outputscale']:6.3f} {row['mean_constant']:6.2f} {reach:7.2f} "
                  f"{row['psi']:6.2f} {row['score']:.2f}")
        successes += float(row["score"]) > 0


def main(argv: list[str] | None = None) -> int:
    if argv is None:
        argv = sys.argv[1:]
    if argv[:1] == ["show"]:
        show(Path(argv[1]), int(argv[2]) if len(argv) > 2 else 5)
        return 0
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", default="box2d")
    parser.add_argument("--skill", default="pour")
    parser.add_argument("--strategy", default="lse2")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--trials", type=int, default=60)
    parser.add_argument("--init", type=int, default=10)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--prior-sd", default=str(LearningConfig.lengthscale_prior_sd))
    parser.add_argument("--no-uniform-if-classified", action="store_true",
                        help="lse2: keep the largest-ψ control when ψ <= 0 for every candidate "
                             "(before LearningConfig.lse2_uniform_if_classified)")
    args = parser.parse_args(argv)
    if args.trials < 1:
        print("lse2_diag: --trials must be >= 1", file=sys.stderr)
        return 2
    try:
        prior_sd = None if args.prior_sd.lower() == "none" else float(args.prior_sd)
        LearningConfig(lengthscale_prior_sd=prior_sd)
    except ValueError:
        print(f"lse2_diag: bad --prior-sd {args.prior_sd!r}", file=sys.stderr)
        return 2
    if args.skill in ("saturated4d", "narrowing5d"):
        from bench.lse2 import saturated_backend

        backend = saturated_backend()
    else:
        backend = load_backend(args.backend)
    spec = backend.skills()[args.skill]
    config = LearningConfig(strategy=args.strategy, budget=args.trials, init=args.init,
                            seed=args.seed, lengthscale_prior_sd=prior_sd,
                            lse2_uniform_if_classified=not args.no_uniform_if_classified)
    rng = np.random.default_rng([config.seed, 0])
    learner = _Learner(spec, config, rng)
    template = RandomModel(spec, 0.0)
    dc = spec.control.dim

    def is_valid(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return backend.is_valid(args.skill, context, controls)

    args.out.parent.mkdir(parents=True, exist_ok=True)
    rows = []
    cpu0 = time.process_time()
    with args.out.open("w") as handle:
        for index in range(config.budget):
            active = goes_active(config, learner.y)
            model = learner.current() if active else None
            context, control = _propose(backend, args.skill, spec, config, rng, model, is_valid)
            unit = template.to_unit(context, control)[0]
            row: dict[str, object] = {"index": index, "active": active,
                                      "context": context.tolist(), "control": control.tolist(),
                                      "unit_control": unit[:dc].round(3).tolist(),
                                      "boundary": bool(np.any(np.abs(unit[:dc]) > BOUNDARY)),
                                      "valid": bool(is_valid(context, control[None])[0])}
            if isinstance(model, LevelSetModel):
                mean, std = model.gp.predict(unit[None])
                row["psi"] = float(-abs(mean[0]) + 1.96 * std[0])
                row.update(mu=float(mean[0]), sigma=float(std[0]),
                           lengthscales=np.round(model.lengthscales, 3).tolist(),
                           mean_constant=round(model.gp.mean_constant, 3),
                           outputscale=round(model.gp.outputscale, 3),
                           noise=round(model.gp.noise, 5), y_scale=round(model.gp.y_scale, 3))
            result, _ = run_trial_safely(backend, args.skill, context, control,
                                         _trial_seed(config.seed, index))
            row["score"] = float(result.score)
            learner.add(unit, float(result.score))
            handle.write(json.dumps(row) + "\n")
            handle.flush()
            rows.append(row)
    chosen = [r for r in rows if r["active"]]
    successes = sum(1 for r in rows if float(r["score"]) > 0)  # type: ignore[arg-type]
    active_successes = sum(1 for r in chosen if float(r["score"]) > 0)  # type: ignore[arg-type]
    boundary = sum(1 for r in chosen if r["boundary"])
    fallback = sum(1 for r in chosen if float(r["psi"]) <= 0)  # type: ignore[arg-type]
    ratio = [float(r["sigma"]) / max(abs(float(r["mu"])), 1e-9) for r in chosen]  # type: ignore[arg-type]
    print(f"{args.skill} {args.strategy} seed {args.seed}: {successes}/{len(rows)} successes, "
          f"{active_successes}/{len(chosen)} among active choices; {boundary}/{len(chosen)} "
          f"active choices on the boundary; {fallback} with psi <= 0; median sigma/|mu| "
          f"{np.median(ratio) if ratio else float('nan'):.2f}; "
          f"CPU {time.process_time() - cpu0:.0f} s")
    backend.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
