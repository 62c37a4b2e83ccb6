"""``lse2``'s uniform control on fully classified slices (issue #21): paired θ* by seed.

``LearningConfig.lse2_uniform_if_classified`` (default on) makes ``lse2`` take a uniform valid
control, not the largest ψ, when ψ ≤ 0 for every candidate of the drawn context. Jobs come
from ``bench.lse2 run --final-only`` (same protocol as the earlier issue #21 runs: 100 trials,
θ* over 50 (pour) / 100 (synthetic) held-out contexts):

* after: ``lse2ctx-runs-synthetic.jsonl``, ``lse2ctx-runs-pour.jsonl`` (the default);
* before: ``lse2ctx-runs-synthetic-before.jsonl`` (``--no-uniform-if-classified``, same code
  otherwise) and, for the pour, ``gpprior-runs-pour-lse2.jsonl`` (the previous session's
  final-only MAP jobs: same code path, as no file the pour's learning uses changed since);
* ``lse`` (unchanged by this: the rule is in ``lse2``'s control choice only) for reference:
  ``gpprior-runs-synthetic.jsonl``/``gpprior-runs-pour-lse.jsonl``.

``python -m bench.lse2_classified`` prints per skill the final θ* per seed and the paired
comparisons after − before (seed-bootstrap 95 % interval: seeds are the units, as a seed's
contexts share one model; pair bootstrap and sign test over (seed, context) pairs; seeds up /
down) and writes ``docs/results/learning/lse2-classified.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from bench.gpprior import _compare, _finals

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "docs" / "results" / "learning"
SKILLS = ("pour", "saturated4d", "narrowing5d")


def report(out: Path) -> dict[str, Any]:
    """Table and paired comparisons (see module doc); writes ``out``."""
    after_logs = [RESULTS / "lse2ctx-runs-synthetic.jsonl", RESULTS / "lse2ctx-runs-pour.jsonl"]
    before_logs = [RESULTS / "lse2ctx-runs-synthetic-before.jsonl",
                   RESULTS / "gpprior-runs-pour-lse2.jsonl"]
    lse_logs = [RESULTS / "gpprior-runs-synthetic.jsonl", RESULTS / "gpprior-runs-pour-lse.jsonl"]
    summary: dict[str, Any] = {}
    for skill in SKILLS:
        table = {"lse2 after": _finals(after_logs, skill, "lse2"),
                 "lse2 before": _finals(before_logs, skill, "lse2"),
                 "lse": _finals(lse_logs, skill, "lse")}
        table = {k: v for k, v in table.items() if v}
        if "lse2 after" not in table:
            continue
        comparisons = [c for a, b in (("lse2 after", "lse2 before"), ("lse2 after", "lse"),
                                      ("lse2 before", "lse"))
                       if a in table and b in table
                       for c in [_compare(a, table[a], b, table[b])] if c is not None]
        rows = {name: {"per_seed": {str(s): round(float(np.mean(v)), 2)
                                    for s, v in sorted(finals.items())},
                       "pooled": round(float(np.mean([x for v in finals.values() for x in v])), 3),
                       "seeds_at_most_0.2": sum(float(np.mean(v)) <= 0.2
                                                for v in finals.values())}
                for name, finals in table.items()}
        summary[skill] = {"rows": rows, "comparisons": comparisons}
        print(f"\n{skill}: final θ* success per seed")
        for name, row in rows.items():
            seeds = " ".join(f"{s}:{v:.2f}" for s, v in row["per_seed"].items())
            print(f"  {name:11} pooled {row['pooled']:.3f} (≤ 0.2 on {row['seeds_at_most_0.2']} "
                  f"seeds)  {seeds}")
        for c in comparisons:
            print(f"  {c['a']} − {c['b']}: {c['mean_diff']:+.3f}, {len(c['seeds'])} seeds "
                  f"({c['seed_wins']} up / {c['seed_losses']} down), seed-bootstrap 95% "
                  f"{c['seed_bootstrap95']}, pair-bootstrap {c['pair_bootstrap95']}, pairs "
                  f"{c['pair_wins']}/{c['pair_losses']} sign p = {c['pair_sign_p']:.2g}")
    payload = {"experiment": "lse2 uniform control on fully classified slices (issue #21)",
               "summary": summary}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(payload, indent=1) + "\n")
    return payload


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.lse2_classified",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=RESULTS / "lse2-classified.json")
    args = parser.parse_args(argv)
    report(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
