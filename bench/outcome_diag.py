"""Why the goal-averaged straddle picks pushes that do not move the object (issue #21).

``python -m bench.outcome_diag --seeds 0-1`` trains ``lse`` with the goal-averaged
straddle ψ̄ (the default before ``outcome-cover``; relabelled trials, al2d standard sizes:
100 trials, 10 random first) on the Box2D push and, at every straddle choice, records for
the chosen candidate and for ``--probe`` uniform candidates of the same batch: the
goal-averaged ``|μ|``, ``σ`` and ψ (score units; the level is 0), and whether the push
moves the object (each probe is simulated once; the chosen one's own trial says). The
choice is unchanged: the wrapper repeats
:func:`ltamp_cli.learning.outcomes.propose_for_all_goals` draw for draw.

Writes ``docs/results/push/outcome-diag.json`` (``--out``): per seed, the per-choice
rows and a summary (means over choices, movers vs non-movers among the probes).
Times are CPU seconds (the machine is shared).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

import ltamp_cli.learning.active as active
from bench.lse2 import _seeds
from bench.push_al import SIZES
from ltamp_cli.backends import load_backend
from ltamp_cli.learning.acquisition import evaluate, first_valid
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.learning.outcomes import ACQUISITION_GOALS

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "results" / "push" / "outcome-diag.json"


def _stats(mean: np.ndarray, std: np.ndarray) -> dict[str, np.ndarray]:
    """Goal-averaged |μ|, σ and ψ per candidate from ``(n, goals)`` arrays."""
    return {"abs_mu": np.abs(mean).mean(axis=1), "sigma": std.mean(axis=1),
            "psi": (-np.abs(mean) + 1.96 * std).mean(axis=1)}


def run_seed(seed: int, probe: int) -> dict[str, Any]:
    backend = load_backend("box2d")
    rows: list[dict[str, Any]] = []

    def proposer(model: Any, rng: np.random.Generator, n_candidates: int, is_valid: Any,
                 n_goals: int = ACQUISITION_GOALS) -> tuple[np.ndarray, np.ndarray] | None:
        # propose_for_all_goals, draw for draw, plus the diagnostics
        spec = model.spec
        goal_columns = spec.control.dim + np.asarray(spec.outcome.goals, dtype=int)
        n_controls = max(1, n_candidates // n_goals)
        candidates = rng.uniform(-1.0, 1.0, size=(n_controls, model.dim))
        goals = rng.uniform(-1.0, 1.0, size=(n_goals, len(goal_columns)))
        points = np.repeat(candidates, n_goals, axis=0)
        points[:, goal_columns] = np.tile(goals, (n_controls, 1))
        mean, std = model.gp.predict(points)
        mean, std = mean.reshape(n_controls, n_goals), std.reshape(n_controls, n_goals)
        psi = evaluate(model.gp, lambda m, s: -abs(m) + 1.96 * s,
                       points).reshape(n_controls, n_goals)
        best_goal = np.argmax(psi, axis=1)
        candidates[:, goal_columns] = goals[best_goal]
        order = np.argsort(-psi.mean(axis=1), kind="stable")
        chosen = first_valid(order, candidates, 1, is_valid)
        if len(chosen) == 0:
            return None
        stats = _stats(mean, std)
        pick = int(chosen[0])
        probes = np.random.default_rng([seed, len(rows), 5]).choice(n_controls, probe,
                                                                    replace=False)
        contexts, controls = model.from_unit(candidates[probes])
        valid = [bool(backend.is_valid("push", c, u[None])[0])
                 for c, u in zip(contexts, controls, strict=True)]
        moved = []
        for c, u, ok in zip(contexts, controls, valid, strict=True):
            if not ok:
                moved.append(None)
                continue
            out = backend.run_trial("push", c, u, 0).outcome
            moved.append(bool(out is not None and np.linalg.norm(out) > 0.05))
        rows.append({
            "chosen": {k: round(float(v[pick]), 4) for k, v in stats.items()},
            "probes": [{**{k: round(float(v[i]), 4) for k, v in stats.items()}, "moved": m}
                       for i, m in zip(probes, moved, strict=True)],
            "chosen_rank_of_abs_mu": float((stats["abs_mu"] < stats["abs_mu"][pick]).mean()),
            "chosen_rank_of_sigma": float((stats["sigma"] < stats["sigma"][pick]).mean())})
        chosen_context, chosen_control = model.from_unit(candidates[pick][None, :])
        return chosen_context[0], chosen_control[0]

    config = LearningConfig(budget=SIZES["budget"], init=SIZES["init"], seed=seed,
                            hindsight_acquisition="goal-mean")
    original = active.propose_for_all_goals
    active.propose_for_all_goals = proposer  # type: ignore[assignment]
    cpu0 = time.process_time()
    try:
        result = learn_online(backend, "push", config)
    finally:
        active.propose_for_all_goals = original  # type: ignore[assignment]
        backend.close()
    cpu = time.process_time() - cpu0
    # the chosen trials' own outcomes: did they move the object?
    straddle = [r for r in result.records[-len(rows):]] if rows else []
    for row, record in zip(rows, straddle, strict=True):
        row["chosen"]["moved"] = bool(record.outcome is not None
                                      and np.linalg.norm(record.outcome) > 0.05)

    def mean_of(items: list[dict[str, Any]], key: str) -> float | None:
        values = [float(i[key]) for i in items]
        return round(float(np.mean(values)), 4) if values else None

    chosen = [r["chosen"] for r in rows]
    probes = [p for r in rows for p in r["probes"] if p["moved"] is not None]
    movers = [p for p in probes if p["moved"]]
    still = [p for p in probes if not p["moved"]]
    summary = {
        "choices": len(rows), "chosen_moved": sum(c["moved"] for c in chosen),
        "probes_valid": len(probes), "probes_moved": len(movers),
        **{f"chosen_{k}": mean_of(chosen, k) for k in ("abs_mu", "sigma", "psi")},
        **{f"movers_{k}": mean_of(movers, k) for k in ("abs_mu", "sigma", "psi")},
        **{f"still_{k}": mean_of(still, k) for k in ("abs_mu", "sigma", "psi")},
        "chosen_mean_rank_abs_mu": round(float(np.mean([r["chosen_rank_of_abs_mu"]
                                                         for r in rows])), 3),
        "chosen_mean_rank_sigma": round(float(np.mean([r["chosen_rank_of_sigma"]
                                                        for r in rows])), 3),
        "cpu_s": round(cpu, 1)}
    return {"seed": seed, "summary": summary, "rows": rows}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.outcome_diag",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="0-1")
    parser.add_argument("--probe", type=int, default=20)
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    results = []
    for seed in _seeds(args.seeds):
        results.append(run_seed(seed, args.probe))
        print(json.dumps({"seed": seed, **results[-1]["summary"]}), flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"experiment": "why the goal-averaged straddle picks "
                                    "pushes that do not move the object (issue #21)",
                                    "sizes": SIZES, "seeds": results}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
