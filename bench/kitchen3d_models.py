"""Shipped Kitchen3D models against chance: θ* vs a uniformly random valid control.

For each model directory (default ``models/kitchen3d/pour`` and ``models/kitchen3d/scoop``)
this runs ``ltamp evaluate``'s own measurement (``ltamp_cli.cli.evaluate._live_success_rates``:
``--contexts`` contexts drawn with ``--seed``, θ* and one uniformly random pre-check-valid
control per context, one live trial each, same trial seed), so its θ* and random columns are
``ltamp evaluate MODEL --trials N --seed S``'s ``success_rate`` and ``random_success_rate``.
What this adds: 95 % Wilson intervals, the gap (target: θ* >= 0.8 and gap >= 0.3), the GP's
context lengthscales (normalised inputs in [-1, 1]; a context input whose lengthscale sits at
the bound is ignored by the model), the CPU seconds per live trial, and every trial run
(context, control, score) in the JSON written to ``--out`` (and, with ``--log``, appended
to a JSONL as each finishes, so a stopped run keeps them).

    OMP_NUM_THREADS=1 .venv/bin/python bench/kitchen3d_models.py --contexts 20
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends import SkillBackend, load_backend
from ltamp_cli.cli.evaluate import _live_success_rates
from ltamp_cli.learning.metrics import wilson_interval
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.threads import use_one_thread

ROOT = Path(__file__).resolve().parents[1]
MODELS_DIR = ROOT / "models" / "kitchen3d"
#: The targets of issue #20: θ* success rate and its gap over random valid controls.
THETA_TARGET = 0.8
GAP_TARGET = 0.3


class TimedBackend:
    """A backend whose ``run_trial`` calls are recorded with their CPU seconds; every other
    attribute is the wrapped backend's."""

    def __init__(self, backend: SkillBackend, log: Path | None = None) -> None:
        self._backend = backend
        self._log = log
        self.trials: list[dict] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self._backend, name)

    def run_trial(self, skill: str, context: np.ndarray, control: np.ndarray,
                  seed: int | None = None) -> Any:
        start = time.process_time()
        result = self._backend.run_trial(skill, context, control, seed=seed)
        self.trials.append({"context": np.asarray(context).tolist(),
                            "control": np.asarray(control).tolist(), "seed": seed,
                            "score": float(result.score), "valid": bool(result.valid),
                            "cpu_s": time.process_time() - start})
        if self._log is not None:  # a stopped run leaves the trials it ran
            with self._log.open("a") as out:
                out.write(json.dumps({"skill": skill, **self.trials[-1]}) + "\n")
        return result


def context_lengthscales(metadata: dict) -> dict[str, float]:
    """The GP's lengthscales of the context inputs, by name (empty for a non-GP model)."""
    hyper = metadata.get("hyperparameters", {})
    names = metadata.get("input_order", [])
    scales = hyper.get("lengthscales", [])
    context_names = set(metadata.get("skill", {}).get("context", {}).get("names", []))
    return {name: float(scale) for name, scale in zip(names, scales, strict=False)
            if name in context_names}


def bench_model(directory: Path, contexts: int, seed: int, log: Path | None = None) -> dict:
    """θ* and random-valid success over ``contexts`` contexts of one model directory."""
    loaded = load_model(directory)
    model, metadata = loaded.model, loaded.metadata
    skill = model.spec.name
    backend = TimedBackend(load_backend(str(metadata.get("backend", "pybullet"))), log)
    try:
        theta_rate, random_rate = _live_success_rates(backend, skill, model, contexts, seed)
    finally:
        backend.close()
    assert theta_rate is not None and random_rate is not None  # contexts >= 1
    cpu = [t["cpu_s"] for t in backend.trials]
    return {
        "model": str(directory), "skill": skill, "contexts": contexts, "seed": seed,
        "n_train": metadata.get("n_train"),
        "theta_success": theta_rate,
        "theta_wilson95": list(wilson_interval(round(theta_rate * contexts), contexts)),
        "random_success": random_rate,
        "random_wilson95": list(wilson_interval(round(random_rate * contexts), contexts)),
        "gap": theta_rate - random_rate,
        "meets_target": theta_rate >= THETA_TARGET and theta_rate - random_rate >= GAP_TARGET,
        "context_lengthscales": context_lengthscales(metadata),
        "cpu_s_per_trial": float(np.mean(cpu)) if cpu else None,
        "trials": backend.trials,
    }


def print_table(summaries: list[dict]) -> None:
    print(f"{'skill':<7}{'n_train':>8}{'θ* (95%)':>18}{'random (95%)':>18}{'gap':>7}"
          f"{'target':>8}{'cpu/trial':>11}")
    for s in summaries:
        met = "yes" if s["meets_target"] else "no"
        theta = f"{s['theta_success']:.2f} ({s['theta_wilson95'][0]:.2f}-" \
                f"{s['theta_wilson95'][1]:.2f})"
        rand = f"{s['random_success']:.2f} ({s['random_wilson95'][0]:.2f}-" \
               f"{s['random_wilson95'][1]:.2f})"
        cpu = "-" if s["cpu_s_per_trial"] is None else f"{s['cpu_s_per_trial']:.2f}s"
        print(f"{s['skill']:<7}{s['n_train']!s:>8}{theta:>18}{rand:>18}{s['gap']:>7.2f}"
              f"{met:>8}{cpu:>11}")
        scales = ", ".join(f"{k}={v:.2f}" for k, v in s["context_lengthscales"].items())
        print(f"  context lengthscales: {scales}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("models", nargs="*", type=Path,
                        default=[MODELS_DIR / "pour", MODELS_DIR / "scoop"])
    parser.add_argument("--contexts", type=int, default=20)
    parser.add_argument("--log", type=Path, default=None,
                        help="append every live trial to this JSONL as it finishes")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path,
                        default=ROOT / "bench" / "results" / "kitchen3d_models.json")
    args = parser.parse_args(argv)
    if args.contexts < 1:
        parser.error("--contexts must be at least 1")
    for directory in args.models:
        if not (directory / "model.json").is_file():
            print(f"kitchen3d_models.py: {directory} holds no model.json", file=sys.stderr)
            return 2
    use_one_thread()
    summaries = [bench_model(directory, args.contexts, args.seed, args.log)
                 for directory in args.models]
    print_table(summaries)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"machine": platform.platform(), "models": summaries},
                                   indent=1))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
