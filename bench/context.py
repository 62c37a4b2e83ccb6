"""Does a skill's success depend on its context? Pour or scoop, Kitchen2D or Kitchen3D.

Issue #20 asks, for pour and scoop in 2D and 3D, to show that success depends on the context.
Two measurements, printed as a table and written to ``--out`` (JSON):

1. **A fixed good control across contexts.** One control runs ``--seeds`` times (trial
   seeds; the beads or grains vary with them) in every one of a set of contexts: a grid over
   the context box (``--grid N1 N2 ...``, points per context dimension, ends included) or
   ``--contexts N`` drawn from the backend's context distribution (seeded by ``--seed``).
   The control is ``--control`` (default: the 2D skills' hand-picked good controls) or θ* of
   the model in ``--model`` at one context, ``--theta-star-at`` (the default for Kitchen3D:
   the centre of the context box). The report gives each context's success rate with its
   95 % Wilson interval (and whether the best and the worst context's intervals are
   disjoint), the overall rate, and for each context dimension the success rate of the
   trials below and above its median with Fisher's exact test of the difference. If success
   did not depend on the context, no split would differ beyond chance.
2. **The GP's context lengthscales.** With ``--trials`` (JSONL trial files: a model's
   ``trials.jsonl``, a ``ltamp collect`` output, a fidelity cache, whose records of
   ``--backend`` are used), a Matérn-5/2 ARD GP fitted by maximum marginal likelihood on the
   valid trials (inputs normalised to [−1, 1]); without, the lengthscales of ``--model``.
   A context lengthscale at the fit's upper bound (``HyperBounds.lengthscale``, 20) says the
   data show no effect of that context input.

Trial seeds: context ``i``'s ``j``-th trial uses ``seed * 100000 + i * seeds + j``, or with
``--common-seeds`` ``seed * 100000 + j`` in every context (common random numbers). With
``--cache`` every trial is appended to that JSONL as it finishes (``bench/fidelity.py``'s
record format) and a rerun reuses it, so a long run resumes.

The committed results (one core, ``OMP_NUM_THREADS=1``):

    # 2D pour: 80 contexts, one trial each; the model's lengthscales
    python bench/context.py --skill pour --backend box2d --contexts 80 \
        --model models/kitchen2d/pour --cache docs/results/fidelity/pour_context_trials.jsonl \
        --out docs/results/fidelity/pour_context.json
    # 2D scoop: a 5 x 3 grid, 8 common seeds; a GP on 548 trials
    python bench/context.py --skill scoop --backend box2d --grid 5 3 --seeds 8 \
        --common-seeds --trials models/kitchen2d/scoop/trials.jsonl \
        docs/results/scoop/random_trials.jsonl --out docs/results/scoop/context.json
    # 3D (PyBullet): θ* of the box centre in 12 contexts, 5 common seeds
    python bench/context.py --skill pour --backend pybullet --contexts 12 --seeds 5 \
        --common-seeds --model models/kitchen3d/pour --trials models/kitchen3d/pour/trials.jsonl \
        docs/results/fidelity/engine_trials.jsonl --cache docs/results/context3d/pour_trials.jsonl \
        --out docs/results/context3d/pour.json
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np
from scipy.stats import fisher_exact

from bench.fidelity import append_record, is_success, load_cache, run_trial, trial_key
from ltamp_cli.backends import SkillBackend, load_backend
from ltamp_cli.learning.gp import HyperBounds, fit_gp
from ltamp_cli.learning.metrics import wilson_interval
from ltamp_cli.learning.normalize import BoxNormalizer, join_inputs, joint_space

ROOT = Path(__file__).resolve().parents[1]
#: Hand-picked good controls of the 2D skills (physical units, the skill's control order).
DEFAULT_CONTROLS: dict[tuple[str, str], tuple[float, ...]] = {
    # a pour from the left of the target, high, nearly upside down (succeeds for mid cups)
    ("box2d", "pour"): (0.8, -1.5, 9.8, 3.1),
    # tilted into the bed, sweep left, turn upright low, lift (tests/box2d/test_scoop.py)
    ("box2d", "scoop"): (0.59, 0.02, 0.84, -0.48, 0.51, 0.51, 0.15),
}
SKILLS = ("pour", "scoop")
#: A context lengthscale above this fraction of the bound counts as "at the bound".
AT_BOUND = 0.95


def grid_contexts(lows: np.ndarray, highs: np.ndarray, counts: list[int]) -> np.ndarray:
    """``(prod(counts), d_context)`` grid points, ``counts[k]`` evenly spaced (ends
    included) along context dimension ``k``; the last dimension varies fastest."""
    axes = [np.linspace(lo, hi, n) if n > 1 else np.array([(lo + hi) / 2])
            for lo, hi, n in zip(lows, highs, counts, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(counts))


def trial_seed(seed: int, index: int, repeat: int, seeds: int, common: bool) -> int:
    """The seed of context ``index``'s ``repeat``-th trial (see the module docstring)."""
    return seed * 100_000 + (repeat if common else index * seeds + repeat)


def rate(labels: np.ndarray) -> dict:
    """Successes, trials, rate and 95 % Wilson interval of boolean ``labels`` ``(n,)``."""
    k, n = int(labels.sum()), len(labels)
    low, high = wilson_interval(k, n)
    return {"successes": k, "n": n, "rate": k / n if n else None, "wilson95": [low, high]}


def splits(contexts: np.ndarray, labels: np.ndarray, names: tuple[str, ...]) -> list[dict]:
    """Success of the trials below / above each context dimension's median (``contexts``
    ``(n, d_context)``, one row per trial), with Fisher's exact test of the difference."""
    rows = []
    for dim, name in enumerate(names):
        median = float(np.median(contexts[:, dim]))
        low = contexts[:, dim] <= median
        table = [[int(labels[low].sum()), int((~labels[low]).sum())],
                 [int(labels[~low].sum()), int((~labels[~low]).sum())]]
        rows.append({"dimension": name, "median": median, "below": rate(labels[low]),
                     "above": rate(labels[~low]), "fisher_p": float(fisher_exact(table)[1])})
    return rows


def fixed_control(backend: SkillBackend, setting: str, skill: str, control: np.ndarray,
                  contexts: np.ndarray, seeds: int, seed: int, common: bool,
                  cache_path: Path | None, progress: bool) -> dict:
    """Run ``control`` ``seeds`` times in each of ``contexts`` ``(m, d_context)`` (cached);
    per-context rows, the overall rate and the median splits."""
    cache = load_cache(cache_path) if cache_path is not None else {}
    rows, records = [], []
    for index, context in enumerate(contexts):
        mine = []
        for repeat in range(seeds):
            tseed = trial_seed(seed, index, repeat, seeds, common)
            key = trial_key(setting, skill, context, control, tseed)
            if key not in cache:
                record = {"key": key, "setting": setting, "skill": skill, "seed": tseed,
                          "context": context.tolist(), "control": control.tolist(),
                          **run_trial(backend, setting, skill, context, control, tseed)}
                if cache_path is not None:
                    append_record(cache_path, record)
                cache[key] = record
            mine.append(cache[key])
        labels = np.array([is_success(r) for r in mine])
        scores = [r["score"] for r in mine if r["score"] is not None]
        rows.append({"context": context.tolist(), **rate(labels),
                     "valid": int(sum(r["valid"] for r in mine)),
                     "mean_score": float(np.mean(scores)) if scores else None,
                     "cpu_s_per_trial": float(np.mean([r["cpu_s"] for r in mine]))})
        records.extend(mine)
        if progress:
            low, high = rows[-1]["wilson95"]
            print(f"  context {index + 1}/{len(contexts)} "
                  f"{np.array2string(context, precision=3)}: {int(labels.sum())}/{seeds} "
                  f"[{low:.2f}, {high:.2f}]", file=sys.stderr, flush=True)
    labels = np.array([is_success(r) for r in records])
    names = backend.skills()[skill].context.names
    lowest = min(rows, key=lambda r: r["rate"])
    highest = max(rows, key=lambda r: r["rate"])
    return {"control": control.tolist(), "seeds_per_context": seeds,
            "common_seeds": common, "overall": rate(labels),
            "valid": int(sum(r["valid"] for r in records)),
            "splits": splits(np.array([r["context"] for r in records]), labels, names),
            "contexts": rows,
            "disjoint": bool(highest["wilson95"][0] > lowest["wilson95"][1]),
            "cpu_s_per_trial": float(np.mean([r["cpu_s"] for r in records]))}


def read_trials(paths: list[Path], skill: str, setting: str
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Contexts ``(n, d_context)``, controls ``(n, d_control)`` and scores ``(n,)`` of the
    valid ``skill`` trials of ``setting`` (a record's ``setting``, else its ``backend``) in
    ``paths``; a trial recorded twice (same context, control and seed) is used once, the same
    input run with other seeds (a fixed control's repeats) once per seed."""
    seen: set[tuple[float | int | None, ...]] = set()
    contexts, controls, scores = [], [], []
    for path in paths:
        for line in path.read_text().splitlines():
            if not line.strip():
                continue
            record = json.loads(line)
            if record.get("skill") != skill:
                continue
            if record.get("setting", record.get("backend")) != setting:
                continue
            if not record.get("valid", False) or record.get("score") is None:
                continue
            key = (*record["context"], *record["control"], record.get("seed"))
            if key in seen:
                continue
            seen.add(key)
            contexts.append(record["context"])
            controls.append(record["control"])
            scores.append(record["score"])
    return np.array(contexts), np.array(controls), np.array(scores, dtype=float)


def bound_summary(lengthscales: dict[str, float], context_names: tuple[str, ...]) -> dict:
    bound = HyperBounds().lengthscale[1]
    below = {name: bool(lengthscales[name] < AT_BOUND * bound) for name in context_names}
    return {"lengthscales": lengthscales, "bound": bound, "context_below_bound": below,
            "all_context_below_bound": all(below.values())}


def fit_lengthscales(backend: SkillBackend, setting: str, skill: str,
                     paths: list[Path]) -> dict:
    """Matérn-5/2 ARD lengthscales (normalised inputs) of a GP on the recorded trials."""
    spec = backend.skills()[skill]
    contexts, controls, scores = read_trials(paths, skill, setting)
    if len(scores) < 2:
        raise ValueError(f"--trials: {len(scores)} valid {setting} {skill} trials (need 2)")
    normalizer = BoxNormalizer.for_space(joint_space(spec))
    x = normalizer.to_unit(join_inputs(spec, contexts, controls))
    start = time.process_time()
    gp = fit_gp(x, scores, "matern52", rng=np.random.default_rng(0))
    names = [*spec.control.names, *spec.context.names]
    scales = dict(zip(names, map(float, gp.lengthscales), strict=True))
    return {"source": "fit", "trials": [str(p) for p in paths], "n_trials": len(scores),
            "successes": int((scores > 0).sum()),
            **bound_summary(scales, spec.context.names),
            "fit_cpu_s": time.process_time() - start}


def model_lengthscales(model_dir: Path) -> dict:
    """The lengthscales saved in a model directory, by input name."""
    meta = json.loads((model_dir / "model.json").read_text())
    scales = dict(zip(meta["input_order"], map(float, meta["hyperparameters"]["lengthscales"]),
                      strict=True))
    training = meta.get("training", {})
    return {"source": "model", "model": str(model_dir), "n_trials": meta.get("n_train"),
            "successes": training.get("n_success"),
            **bound_summary(scales, tuple(meta["skill"]["context"]["names"]))}


def theta_star(model_dir: Path, backend: SkillBackend, skill: str, context: np.ndarray,
               seed: int) -> tuple[np.ndarray, float]:
    """θ* ``(d_control,)`` of the model in ``model_dir`` at ``context`` and its μ/σ."""
    from ltamp_cli.learning.model_dir import load_model

    model = load_model(model_dir).model
    if model.spec.name != skill:
        raise ValueError(f"--model: {model_dir} is a {model.spec.name} model, not {skill}")
    control, confidence = model.most_confident_control(
        context, np.random.default_rng(seed), lambda c, u: backend.is_valid(skill, c, u))
    return np.asarray(control, dtype=float), float(confidence)


def print_report(report: dict) -> None:
    fixed = report["fixed_control"]
    overall = fixed["overall"]
    lo, hi = overall["wilson95"]
    control = ", ".join(f"{v:.3g}" for v in fixed["control"])
    print(f"{report['backend']} {report['skill']}: fixed control ({control}), "
          f"{fixed['seeds_per_context']} trial(s) in each of {len(fixed['contexts'])} contexts")
    print(f"overall {overall['successes']}/{overall['n']} succeed ({lo:.2f}-{hi:.2f}); "
          f"{fixed['cpu_s_per_trial']:.2f} s CPU per trial")
    if fixed["seeds_per_context"] > 1:
        print(f"{'context':<40} {'success':>8} {'wilson95':>11} {'mean score':>11}")
        for row in fixed["contexts"]:
            ctx = ", ".join(f"{v:.3g}" for v in row["context"])
            mean = "-" if row["mean_score"] is None else f"{row['mean_score']:.2f}"
            print(f"{ctx:<40} {row['successes']:>3}/{row['n']:<4} "
                  f"{row['wilson95'][0]:5.2f}-{row['wilson95'][1]:.2f} {mean:>11}")
        print(f"best vs worst context: intervals disjoint: {fixed['disjoint']}")
    print(f"{'context dim':<20} {'median':>7} {'below: rate (95%)':>23} "
          f"{'above: rate (95%)':>23} {'Fisher p':>9}")
    for row in fixed["splits"]:
        cells = [f"{row[s]['successes']:>3}/{row[s]['n']:<3} {row[s]['rate']:.2f} "
                 f"({row[s]['wilson95'][0]:.2f}-{row[s]['wilson95'][1]:.2f})"
                 for s in ("below", "above")]
        print(f"{row['dimension']:<20} {row['median']:>7.3g} {cells[0]:>23} {cells[1]:>23} "
              f"{row['fisher_p']:>9.2g}")
    for key in ("gp", "model_gp"):
        gp = report.get(key)
        if gp:
            scales = ", ".join(f"{k} {v:.2f}" for k, v in gp["lengthscales"].items())
            print(f"GP ({gp['source']}, {gp['n_trials']} trials, {gp['successes']} successes; "
                  f"bound {gp['bound']:g}): {scales}")
            print(f"  context lengthscales below the bound: {gp['context_below_bound']}")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--skill", choices=SKILLS, required=True)
    parser.add_argument("--backend", default="box2d", help="box2d, pybullet or sapien")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--contexts", type=int, default=0, help="contexts drawn (seeded)")
    where.add_argument("--grid", type=int, nargs="+", default=None,
                       help="grid points per context dimension")
    parser.add_argument("--seeds", type=int, default=1, help="trials per context")
    parser.add_argument("--common-seeds", action="store_true",
                        help="the same trial seeds in every context")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--control", type=float, nargs="+", default=None)
    parser.add_argument("--theta-star-at", type=float, nargs="+", default=None,
                        help="use --model's θ* at this context as the fixed control")
    parser.add_argument("--model", type=Path, default=None)
    parser.add_argument("--trials", type=Path, nargs="*", default=[],
                        help="JSONL trial files for the GP fit")
    parser.add_argument("--min-trials", type=int, default=0,
                        help="fail if the GP fit has fewer valid trials")
    parser.add_argument("--cache", type=Path, default=None, help="JSONL trial cache (resumes)")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")
    if args.grid is None and args.contexts < 2:
        parser.error("give --contexts N (N >= 2) or --grid N1 N2 ...")
    if args.control is not None and args.theta_star_at is not None:
        parser.error("--control and --theta-star-at exclude each other")
    if args.theta_star_at is not None and args.model is None:
        parser.error("--theta-star-at needs --model")
    for path in [*args.trials, *([args.model / "model.json"] if args.model else [])]:
        if not path.is_file():
            parser.error(f"{path}: no such file")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        backend = load_backend(args.backend)
    except (KeyError, ValueError) as error:
        print(f"context.py: --backend: {error}", file=sys.stderr)
        return 2
    try:
        spec = backend.skills().get(args.skill)
        if spec is None:
            print(f"context.py: backend {args.backend} has no skill {args.skill}",
                  file=sys.stderr)
            return 2
        report: dict = {"machine": platform.platform(), "skill": args.skill,
                        "backend": args.backend, "seed": args.seed}
        lows, highs = np.asarray(spec.context.lows), np.asarray(spec.context.highs)
        if args.grid is not None:
            if len(args.grid) != spec.context.dim or min(args.grid) < 1:
                print(f"context.py: --grid needs {spec.context.dim} counts >= 1",
                      file=sys.stderr)
                return 2
            contexts = grid_contexts(lows, highs, args.grid)
        else:
            rng = np.random.default_rng(args.seed)
            contexts = np.array([backend.sample_context(args.skill, rng)
                                 for _ in range(args.contexts)])
        if args.control is not None:
            control = np.array(args.control, dtype=float)
        elif args.model is not None and (args.theta_star_at is not None
                                         or (args.backend, args.skill) not in DEFAULT_CONTROLS):
            at = (np.array(args.theta_star_at, dtype=float) if args.theta_star_at is not None
                  else (lows + highs) / 2)
            if at.shape != (spec.context.dim,):
                print(f"context.py: --theta-star-at needs {spec.context.dim} values",
                      file=sys.stderr)
                return 2
            control, confidence = theta_star(args.model, backend, args.skill, at, args.seed)
            report["theta_star"] = {"context": at.tolist(), "confidence": confidence}
        elif (args.backend, args.skill) in DEFAULT_CONTROLS:
            control = np.array(DEFAULT_CONTROLS[(args.backend, args.skill)], dtype=float)
        else:
            print("context.py: give --control or --model", file=sys.stderr)
            return 2
        c_lows, c_highs = np.asarray(spec.control.lows), np.asarray(spec.control.highs)
        if control.shape != c_lows.shape or not np.all((control >= c_lows)
                                                       & (control <= c_highs)):
            print(f"context.py: the control is not in the {args.skill}'s control box",
                  file=sys.stderr)
            return 2
        if args.cache is not None:
            args.cache.parent.mkdir(parents=True, exist_ok=True)
        report["fixed_control"] = fixed_control(
            backend, args.backend, args.skill, control, contexts, args.seeds, args.seed,
            args.common_seeds, args.cache, not args.quiet)
        if args.trials:
            report["gp"] = fit_lengthscales(backend, args.backend, args.skill, args.trials)
            if report["gp"]["n_trials"] < args.min_trials:
                print(f"context.py: only {report['gp']['n_trials']} valid trials "
                      f"(need {args.min_trials})", file=sys.stderr)
                return 2
            if args.model is not None:
                report["model_gp"] = model_lengthscales(args.model)
        elif args.model is not None:
            report["gp"] = model_lengthscales(args.model)
    except ValueError as error:
        print(f"context.py: {error}", file=sys.stderr)
        return 2
    finally:
        backend.close()
    print_report(report)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=1) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
