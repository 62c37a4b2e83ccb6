"""The GP fit's lengthscale prior (issue #21): hyperparameters, fit cost and paired θ* results.

``python -m bench.gpprior fits`` refits the shipped 2D pour model's trials
(``models/kitchen2d/pour/trials.jsonl``, 250) with the fit before issue #21 (maximum marginal
likelihood, ``prior=None``) and with the default MAP fit (:data:`~ltamp_cli.learning.gp.
DEFAULT_PRIOR`), prints the lengthscales next to the shipped ``model.json``'s, and measures CPU
seconds per cold fit (2 random restarts, as the final fit of ``ltamp train``) on the first 100
and all 250 trials (median of ``--repeats``). Writes ``docs/results/learning/gpprior-fits.json``.

``python -m bench.gpprior refit-diag`` reads the per-trial diagnostics of
``bench.lse2_diag`` (default: pour ``lse2`` seeds 2 and 3, maximum-likelihood fit,
``diag/pour-lse2-after-seed{2,3}.jsonl``), prints the hyperparameters that run fitted over the
trials, and refits the same trials' prefixes (n = 20, 30, …) cold with and without the prior.
Writes ``docs/results/learning/gpprior-refit-diag.json``.

``python -m bench.gpprior report`` reads ``bench.lse2`` job logs — the MAP fit's
(``gpprior-runs*.jsonl``) and the maximum-likelihood fit's (``lse2-runs.jsonl`` of the previous
session, ``gpprior-ml-runs*.jsonl`` of this one, and the standard paper run's pour jobs, same
protocol and code path) — and prints,
per skill, each learner's final θ* success per seed and the paired differences MAP − ML
(same learner) and between learners under MAP, each with a 95 % bootstrap interval over
*seeds* (the seed is the unit: its held-out contexts share one model) and over (seed, context)
pairs, and the sign test over (seed, context) pairs. Writes ``docs/results/learning/gpprior.json``.

Times are CPU seconds of this process (the machine is shared; wall time means little).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "docs" / "results" / "learning"
POUR_MODEL = REPO / "models" / "kitchen2d" / "pour"


def _pour_data() -> tuple[Any, np.ndarray, np.ndarray, dict[str, Any]]:
    """The shipped pour model's skill, training inputs ``(250, 8)`` normalised, scores
    ``(250,)`` and its hyperparameters before the refit with the prior (the maximum
    likelihood fit it was trained with)."""
    from ltamp_cli.learning.model import LevelSetModel
    from ltamp_cli.learning.model_dir import load_model

    model = load_model(str(POUR_MODEL)).model
    assert isinstance(model, LevelSetModel)
    metadata = json.loads((POUR_MODEL / "model.json").read_text())
    # Since the shipped model was itself refitted with the prior (``ltamp train --refit``),
    # the fit it was shipped with before is kept under ``refit``.
    shipped = (metadata.get("refit", {}).get("previous_hyperparameters")
               or metadata["hyperparameters"])
    return model.spec, model.gp.x_np, model.gp.y_np, shipped


def fits(repeats: int, out: Path) -> dict[str, Any]:
    """Shipped pour model refitted with and without the prior; CPU per cold fit."""
    from ltamp_cli.learning.active import gp_bounds
    from ltamp_cli.learning.gp import DEFAULT_PRIOR, fit_gp

    spec, x, y, shipped = _pour_data()
    names = [*spec.control.names, *spec.context.names]
    settings = {"ML (before)": None, "MAP (default prior)": DEFAULT_PRIOR}
    rows: dict[str, Any] = {"shipped model.json": {"lengthscales": shipped["lengthscales"],
                                                   "noise": shipped["noise"],
                                                   "outputscale": shipped["outputscale"]}}
    cost: dict[str, dict[str, float]] = {}
    for label, prior in settings.items():
        for n in (100, len(y)):
            times = []
            for _ in range(repeats):
                cpu0 = time.process_time()
                gp = fit_gp(x[:n], y[:n], "matern52", restarts=2,
                            rng=np.random.default_rng(0), bounds=gp_bounds(spec), prior=prior)
                times.append(time.process_time() - cpu0)
            cost.setdefault(label, {})[str(n)] = round(float(np.median(times)), 3)
            if n == len(y):
                rows[label] = {"lengthscales": gp.lengthscales.round(3).tolist(),
                               "noise": round(gp.noise, 4), "outputscale": round(gp.outputscale, 4),
                               "nll_per_point": round(gp.nll, 4)}
    print(f"shipped pour model: {len(y)} trials ({int((y > 0).sum())} successes); lengthscales "
          "in normalised units ([-1, 1] box)")
    print(f"{'fit':22} " + " ".join(f"{n[:8]:>8}" for n in names) + "    noise  outsc.")
    for label, row in rows.items():
        print(f"{label:22} " + " ".join(f"{v:8.3f}" for v in row["lengthscales"])
              + f" {row['noise']:8.4f} {row['outputscale']:7.4f}")
    print(f"\nCPU s per cold fit (2 restarts, median of {repeats}; loaded machine):")
    for label, entry in cost.items():
        print(f"  {label:22} " + ", ".join(f"{n} points {v:.3f} s" for n, v in entry.items()))
    payload = {"experiment": "gpprior fits (issue #21)", "inputs": names, "fits": rows,
               "cpu_s_per_fit": cost, "repeats": repeats}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(payload, indent=1) + "\n")
    return payload


def refit_diag(paths: list[Path], out: Path) -> dict[str, Any]:
    """Hyperparameters of a logged run over its trials, and cold refits ML vs MAP."""
    from ltamp_cli.backends import load_backend
    from ltamp_cli.learning.active import _training_score, gp_bounds
    from ltamp_cli.learning.baselines import RandomModel
    from ltamp_cli.learning.gp import DEFAULT_PRIOR, fit_gp

    backend = load_backend("box2d")
    spec = backend.skills()["pour"]
    template = RandomModel(spec, 0.0)
    payload: dict[str, Any] = {"experiment": "gpprior refit-diag (issue #21)",
                               "inputs": [*spec.control.names, *spec.context.names], "runs": {}}
    for path in paths:
        rows = [json.loads(line) for line in path.read_text().splitlines()]
        x = np.array([template.to_unit(np.array(r["context"]), np.array(r["control"]))[0]
                      for r in rows])
        y = np.array([_training_score(spec, float(r["score"])) for r in rows])
        logged = {int(r["index"]): r["lengthscales"] for r in rows if "lengthscales" in r}
        print(f"\n{path.name}: {len(rows)} trials, {int((y > 0).sum())} successes; "
              "lengthscales [control (4) | context (4)], normalised units")
        for index in sorted(logged)[::5]:
            print(f"  logged before trial {index:3d}: "
                  + " ".join(f"{v:6.2f}" for v in logged[index]))
        refits: dict[str, Any] = {}
        for n in range(20, len(rows) + 1, 10):
            for label, prior in (("ML", None), ("MAP", DEFAULT_PRIOR)):
                gp = fit_gp(x[:n], y[:n], "matern52", restarts=2, rng=np.random.default_rng(0),
                            bounds=gp_bounds(spec), prior=prior)
                refits.setdefault(str(n), {})[label] = gp.lengthscales.round(3).tolist()
                print(f"  refit n={n:3d} {label:3}: "
                      + " ".join(f"{v:6.2f}" for v in gp.lengthscales)
                      + f"   ({int((y[:n] > 0).sum())} successes)")
        payload["runs"][path.name] = {"logged": {str(k): v for k, v in logged.items()},
                                      "refits": refits}
    backend.close()
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(payload, indent=1) + "\n")
    return payload


def _finals(paths: list[Path], skill: str, learner: str) -> dict[int, list[float]]:
    from bench.lse2 import _read_log

    return {seed: [float(v) for v in job["curve"][-1]["successes"]]
            for path in paths for (s, lr, seed), job in _read_log(path).items()
            if s == skill and lr == learner}


def _seed_bootstrap(diffs: dict[int, np.ndarray], n_boot: int = 10_000) -> list[float]:
    """95 % percentile interval of the mean difference, resampling seeds (clusters)."""
    seeds = sorted(diffs)
    per_seed = np.array([diffs[s].mean() for s in seeds])
    sizes = np.array([diffs[s].size for s in seeds])
    rng = np.random.default_rng(0)
    picks = rng.integers(0, len(seeds), size=(n_boot, len(seeds)))
    means = (per_seed[picks] * sizes[picks]).sum(1) / sizes[picks].sum(1)
    return [round(float(np.quantile(means, 0.025)), 3), round(float(np.quantile(means, 0.975)), 3)]


def _compare(a_name: str, a: dict[int, list[float]], b_name: str,
             b: dict[int, list[float]]) -> dict[str, Any] | None:
    from bench.paper.stats import paired_comparison

    seeds = sorted(set(a) & set(b))
    if not seeds:
        return None
    diffs = {s: np.array(a[s]) - np.array(b[s]) for s in seeds}
    flat_a = [v for s in seeds for v in a[s]]
    flat_b = [v for s in seeds for v in b[s]]
    c = paired_comparison(a_name, flat_a, b_name, flat_b)
    per_seed = [round(float(diffs[s].mean()), 2) for s in seeds]
    return {"a": a_name, "b": b_name, "seeds": seeds, "per_seed_diff": per_seed,
            "seed_wins": sum(d > 0 for d in per_seed), "seed_losses": sum(d < 0 for d in per_seed),
            "mean_diff": round(c.difference, 3), "seed_bootstrap95": _seed_bootstrap(diffs),
            "pair_bootstrap95": [round(c.low, 3), round(c.high, 3)], "pair_sign_p": c.p_value,
            "pair_wins": c.wins, "pair_losses": c.losses, "verdict_pairs": c.verdict}


def report(map_logs: list[Path], ml_logs: list[Path], standard_log: Path,
           out: Path) -> dict[str, Any]:
    from bench.lse2 import SIZES, _standard_jobs

    summary: dict[str, Any] = {}
    standard = _standard_jobs(standard_log)
    for skill in SIZES:
        table: dict[str, dict[int, list[float]]] = {}
        for learner in ("random", "lse", "lse2"):
            mapped = _finals(map_logs, skill, learner)
            ml = _finals(ml_logs, skill, learner)
            if skill == "pour":
                for (s, lr, seed), job in standard.items():
                    if s == skill and lr == learner and seed not in ml:
                        ml[seed] = [float(v) for v in job["curve"][-1]["successes"]]
            if learner == "random":  # no GP: the prior cannot change it
                mapped = {**ml, **mapped}
            if mapped:
                table[f"{learner} MAP"] = mapped
            if ml and learner != "random":
                table[f"{learner} ML"] = ml
        if not table:
            continue
        comparisons = []
        for a, b in (("lse2 MAP", "lse2 ML"), ("lse MAP", "lse ML"), ("lse2 MAP", "lse MAP"),
                     ("lse MAP", "random MAP"), ("lse2 MAP", "random MAP")):
            if a in table and b in table:
                c = _compare(a, table[a], b, table[b])
                if c is not None:
                    comparisons.append(c)
        rows = {name: {"per_seed": {str(s): round(float(np.mean(v)), 2)
                                    for s, v in sorted(finals.items())},
                       "pooled": round(float(np.mean([x for v in finals.values() for x in v])), 3)}
                for name, finals in table.items()}
        summary[skill] = {"rows": rows, "comparisons": comparisons}
        print(f"\n{skill}: final θ* success per seed (ML = max. marginal likelihood, before; "
              "MAP = default lengthscale prior)")
        for name, row in rows.items():
            seeds = " ".join(f"{s}:{v:.2f}" for s, v in row["per_seed"].items())
            print(f"  {name:11} pooled {row['pooled']:.3f}  {seeds}")
        for c in comparisons:
            print(f"  {c['a']} − {c['b']}: {c['mean_diff']:+.3f}, seeds {c['seeds'][0]}–"
                  f"{c['seeds'][-1]} ({c['seed_wins']} up / {c['seed_losses']} down), "
                  f"seed-bootstrap 95% {c['seed_bootstrap95']}, pair-bootstrap "
                  f"{c['pair_bootstrap95']}, pairs {c['pair_wins']}/{c['pair_losses']} sign "
                  f"p = {c['pair_sign_p']:.2g} ({c['verdict_pairs']})")
    # lse2 − lse under MAP over every (skill, seed) unit: the default strategy's question
    units = [(skill, d) for skill, entry in summary.items() for c in entry["comparisons"]
             if (c["a"], c["b"]) == ("lse2 MAP", "lse MAP") for d in c["per_seed_diff"]]
    overall: dict[str, Any] = {}
    if units:
        diffs = np.array([d for _, d in units])
        rng = np.random.default_rng(0)
        boots = diffs[rng.integers(0, diffs.size, size=(10_000, diffs.size))].mean(1)
        overall = {"units": len(units), "mean": round(float(diffs.mean()), 3),
                   "bootstrap95": [round(float(np.quantile(boots, 0.025)), 3),
                                   round(float(np.quantile(boots, 0.975)), 3)],
                   "up": int((diffs > 0).sum()), "down": int((diffs < 0).sum())}
        print(f"\nlse2 MAP − lse MAP over {overall['units']} (skill, seed) units: "
              f"{overall['mean']:+.3f}, bootstrap 95% {overall['bootstrap95']}, "
              f"{overall['up']} up / {overall['down']} down")
    payload = {"experiment": "gpprior (issue #21)", "summary": summary,
               "lse2_minus_lse_all_skills": overall}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(payload, indent=1) + "\n")
    return payload


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.gpprior",
                                     description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    fit_p = sub.add_parser("fits", help="shipped pour model refit and CPU per fit")
    fit_p.add_argument("--repeats", type=int, default=3)
    fit_p.add_argument("--out", type=Path, default=RESULTS / "gpprior-fits.json")
    diag = sub.add_parser("refit-diag", help="hyperparameters over a logged run; refits")
    diag.add_argument("paths", type=Path, nargs="*",
                      default=[RESULTS / "diag" / f"pour-lse2-after-seed{s}.jsonl"
                               for s in (2, 3)])
    diag.add_argument("--out", type=Path, default=RESULTS / "gpprior-refit-diag.json")
    rep = sub.add_parser("report", help="paired θ* comparisons MAP vs ML")
    rep.add_argument("--map-log", type=Path, nargs="+",
                     default=sorted(RESULTS.glob("gpprior-runs*.jsonl")))
    rep.add_argument("--ml-log", type=Path, nargs="+",
                     default=[RESULTS / "lse2-runs.jsonl",
                              *sorted(RESULTS.glob("gpprior-ml-runs*.jsonl"))])
    rep.add_argument("--standard-log", type=Path,
                     default=REPO / "docs" / "results" / "standard" / "runs"
                     / "al2d-pour-standard.jsonl")
    rep.add_argument("--out", type=Path, default=RESULTS / "gpprior.json")
    args = parser.parse_args(argv)
    if args.command == "fits":
        if args.repeats < 1:
            print("bench.gpprior: --repeats must be >= 1", file=sys.stderr)
            return 2
        fits(args.repeats, args.out)
    elif args.command == "refit-diag":
        refit_diag(args.paths, args.out)
    else:
        report(args.map_log, args.ml_log, args.standard_log, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
