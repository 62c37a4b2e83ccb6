"""Shipped Kitchen3D models against chance: θ* vs a uniformly random valid control.

For each model directory (default ``models/kitchen3d/pour`` and ``models/kitchen3d/scoop``)
this draws ``--contexts`` contexts exactly as ``ltamp evaluate --trials N --seed S`` does
(same generator, same θ* and the same trial seeds, so its θ* column is ``evaluate``'s success
rate) and, in each context, one uniformly random control that passes the skill's
pre-check (from a second generator, so θ* is unchanged). Both run as live trials on the
model's backend with the same trial seed. The table gives both success rates, their gap
(target: θ* >= 0.8 and gap >= 0.3), the context lengthscales of the GP (normalised inputs
in [-1, 1]; a context input whose lengthscale sits at the bound is ignored by the model) and
the CPU seconds per trial. The rows are written as JSON to ``--out``.

    OMP_NUM_THREADS=1 .venv/bin/python bench/kitchen3d_models.py --contexts 20
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np

from ltamp_cli.backends import SkillBackend, load_backend
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.threads import use_one_thread

MODELS_DIR = Path(__file__).resolve().parents[1] / "models" / "kitchen3d"
#: The targets of issue #20: θ* success rate and its gap over random valid controls.
THETA_TARGET = 0.8
GAP_TARGET = 0.3
#: Uniform draws per context when looking for a control that passes the pre-check.
RANDOM_DRAWS = 256


def random_valid_control(backend: SkillBackend, skill: str, context: np.ndarray,
                         rng: np.random.Generator) -> np.ndarray:
    """The first of up to :data:`RANDOM_DRAWS` uniform controls ``(d_control,)`` that the
    pre-check accepts (the first draw when none does)."""
    spec = backend.skills()[skill]
    controls = spec.control.sample_uniform(rng, RANDOM_DRAWS)
    for control in controls:
        if backend.is_valid(skill, context, control[None])[0]:
            return control
    return controls[0]


def context_lengthscales(metadata: dict) -> dict[str, float]:
    """The GP's lengthscales of the context inputs, by name (empty for a non-GP model)."""
    hyper = metadata.get("hyperparameters", {})
    names = metadata.get("input_order", [])
    scales = hyper.get("lengthscales", [])
    context_names = set(metadata.get("skill", {}).get("context", {}).get("names", []))
    return {name: float(scale) for name, scale in zip(names, scales, strict=False)
            if name in context_names}


def bench_model(directory: Path, contexts: int, seed: int) -> dict:
    """θ* and random-valid success over ``contexts`` contexts of one model directory."""
    loaded = load_model(directory)
    model, metadata = loaded.model, loaded.metadata
    skill = model.spec.name
    backend = load_backend(str(metadata.get("backend", "pybullet")))
    rng = np.random.default_rng(seed)
    random_rng = np.random.default_rng(seed + 1)
    rows = []
    try:
        for index in range(contexts):
            context = backend.sample_context(skill, rng)
            theta, confidence = model.most_confident_control(
                context, rng, lambda c, u: backend.is_valid(skill, c, u))
            uniform = random_valid_control(backend, skill, context, random_rng)
            trial_seed = seed * 100_003 + index  # as `ltamp evaluate`
            row: dict = {"context": context.tolist(), "confidence": float(confidence)}
            for name, control in (("theta", theta), ("random", uniform)):
                start = time.process_time()
                result = backend.run_trial(skill, context, control, seed=trial_seed)
                row[name] = {"control": np.asarray(control).tolist(), "score": result.score,
                             "valid": result.valid,
                             "success": bool(result.valid and result.score > 0),
                             "cpu_s": time.process_time() - start}
            rows.append(row)
    finally:
        backend.close()
    theta_rate = float(np.mean([row["theta"]["success"] for row in rows]))
    random_rate = float(np.mean([row["random"]["success"] for row in rows]))
    return {
        "model": str(directory), "skill": skill, "contexts": contexts, "seed": seed,
        "n_train": metadata.get("n_train"),
        "theta_success": theta_rate, "random_success": random_rate,
        "gap": theta_rate - random_rate,
        "meets_target": theta_rate >= THETA_TARGET and theta_rate - random_rate >= GAP_TARGET,
        "context_lengthscales": context_lengthscales(metadata),
        "cpu_s_per_trial": float(np.mean([row[k]["cpu_s"] for row in rows
                                          for k in ("theta", "random")])),
        "rows": rows,
    }


def print_table(summaries: list[dict]) -> None:
    print(f"{'skill':<7}{'n_train':>8}{'θ*':>7}{'random':>8}{'gap':>7}{'target':>8}"
          f"{'cpu/trial':>11}")
    for s in summaries:
        met = "yes" if s["meets_target"] else "no"
        print(f"{s['skill']:<7}{s['n_train']!s:>8}{s['theta_success']:>7.2f}"
              f"{s['random_success']:>8.2f}{s['gap']:>7.2f}{met:>8}"
              f"{s['cpu_s_per_trial']:>10.2f}s")
        scales = ", ".join(f"{k}={v:.2f}" for k, v in s["context_lengthscales"].items())
        print(f"  context lengthscales: {scales}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("models", nargs="*", type=Path,
                        default=[MODELS_DIR / "pour", MODELS_DIR / "scoop"])
    parser.add_argument("--contexts", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("bench/results/kitchen3d_models.json"))
    args = parser.parse_args(argv)
    if args.contexts < 1:
        parser.error("--contexts must be at least 1")
    use_one_thread()
    summaries = [bench_model(directory, args.contexts, args.seed) for directory in args.models]
    print_table(summaries)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"machine": platform.platform(), "models": summaries},
                                   indent=1))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
