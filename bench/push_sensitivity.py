"""How stable is a 3D push's label within each engine? Sub-millimetre pad shifts, per engine.

The ``3d-push-engine`` row of :mod:`bench.fidelity` compares PyBullet's and SAPIEN's labels
(``valid and score > 0``) on 200 random valid push inputs. Where an engine's own label
changes when the pad's path moves by a fraction of a millimetre, no second engine can be
expected to reproduce it, and the row's agreement is bounded by that noise, not by a
physical difference. This measures it.

For the row's inputs (the same draw, :func:`bench.fidelity.draw_inputs`, and the same
trial seeds), each engine runs every input as drawn and again with the pad's lateral
offset moved sideways by each of ``--shifts-mm`` (default ±0.1 and ±0.2 mm: the control's
``lateral_offset``, a fraction of the block side, changes by ``shift / side``). An input is
*robust* on an engine when all its runs give the same label; its *majority label* is the
label most of its runs give (the number of runs is odd by default).

The table gives, per engine, the robust fraction with its 95 % Wilson interval and the
label flips per shift; then the PyBullet-vs-SAPIEN agreement on all inputs (the row's
number, from the unshifted runs), on the inputs robust on both engines, on those robust
on PyBullet, and between the majority labels. The summary is written to ``--out``
(default ``bench/results/push_sensitivity.json``). The committed run (about 60 s CPU):

    OMP_NUM_THREADS=1 .venv/bin/python bench/push_sensitivity.py \
        --out docs/results/fidelity/push_sensitivity.json

``--pybullet-breaking-m`` is a what-if: PyBullet's push world with another contact breaking
threshold. Since issue #20 the push world ships with Bullet's default 2 cm
(:data:`ltamp_cli.backends.pybullet.world.SKILL_CONTACT_BREAKING_M`: the pad keeps 2-3 contact
points on the block); with the 4 mm the bead worlds keep it had one, and its labels were
chaotic. The committed run of the push as it was before:

    OMP_NUM_THREADS=1 .venv/bin/python bench/push_sensitivity.py --pybullet-breaking-m 0.004 \
        --out docs/results/fidelity/push_sensitivity_breaking_4mm.json
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

import numpy as np

from bench.fidelity import (
    RESULTS_DIR,
    SETTINGS,
    draw_inputs,
    is_success,
    run_trial,
    setting_version,
    wilson_interval,
)
from ltamp_cli.backends import SkillBackend, load_backend

ENGINES = ("pybullet", "sapien")
SKILL = "push"
#: Default sideways shifts (mm) of the pad's path.
DEFAULT_SHIFTS_MM = (-0.2, -0.1, 0.1, 0.2)


def shifted_control(context: np.ndarray, control: np.ndarray, shift_m: float) -> np.ndarray:
    """The push control ``(4,)`` with the pad's lateral offset moved by ``shift_m`` metres
    (``lateral_offset`` is a fraction of the block side ``context[0]``)."""
    moved = np.array(control, dtype=float)
    moved[2] += shift_m / float(context[0])
    return moved


def rate(count: int, n: int) -> dict:
    """``count / n`` with its 95 % Wilson interval."""
    low, high = wilson_interval(count, n)
    return {"count": count, "n": n, "rate": count / n if n else None, "wilson95": [low, high]}


def engine_summary(labels: np.ndarray, shifts_mm: tuple[float, ...]) -> dict:
    """Robustness of one engine's labels ``(n, 1 + k)`` (column 0: as drawn, then one
    column per shift in ``shifts_mm``); the labels themselves are kept as 0/1 lists."""
    robust = (labels == labels[:, :1]).all(axis=1)
    return {
        "robust": rate(int(robust.sum()), len(labels)),
        "flips_per_shift": {f"{s:+g}": int((labels[:, j + 1] != labels[:, 0]).sum())
                            for j, s in enumerate(shifts_mm)},
        "success_as_drawn": float(labels[:, 0].mean()),
        "unstable_inputs": [int(i) for i in np.flatnonzero(~robust)],
        "labels": labels.astype(int).tolist(),
    }


def majority(labels: np.ndarray) -> np.ndarray:
    """The label most runs give, bool ``(n,)`` (ties, possible with an even number of runs,
    count as failures)."""
    return labels.mean(axis=1) > 0.5


def cross_summary(bullet: np.ndarray, sapien: np.ndarray) -> dict:
    """PyBullet-vs-SAPIEN agreement from two engines' label arrays ``(n, 1 + k)``."""
    robust_b = (bullet == bullet[:, :1]).all(axis=1)
    robust_s = (sapien == sapien[:, :1]).all(axis=1)
    agree = bullet[:, 0] == sapien[:, 0]
    both = robust_b & robust_s
    return {
        "agreement_all": rate(int(agree.sum()), len(agree)),
        "agreement_robust_on_both": rate(int(agree[both].sum()), int(both.sum())),
        "agreement_robust_on_pybullet": rate(int(agree[robust_b].sum()), int(robust_b.sum())),
        "agreement_majority": rate(int((majority(bullet) == majority(sapien)).sum()),
                                   len(agree)),
        "disagreements": [
            {"input": int(i), "pybullet": bool(bullet[i, 0]), "sapien": bool(sapien[i, 0]),
             "pybullet_robust": bool(robust_b[i]), "sapien_robust": bool(robust_s[i])}
            for i in np.flatnonzero(~agree)
        ],
    }


@contextmanager
def engine_backends(breaking_m: float | None) -> Iterator[dict[str, SkillBackend]]:
    """Both engines' backends as shipped, closed on exit; with ``breaking_m`` PyBullet's
    push world's contact breaking threshold (m, shipped: 0.02) is replaced (a what-if)."""
    with ExitStack() as stack:
        built = {}
        for engine in ENGINES:
            if engine == "pybullet" and breaking_m is not None:
                backend = load_backend("pybullet", contact_breaking_m={SKILL: breaking_m})
            else:
                backend = SETTINGS[engine]()
            stack.callback(backend.close)
            built[engine] = backend
        yield built


def measure(n: int, seed: int, shifts_mm: tuple[float, ...], progress: bool,
            breaking_m: float | None = None) -> dict:
    """Run every input on both engines, as drawn and shifted; the JSON summary."""
    labels: dict[str, np.ndarray] = {}
    cpu: dict[str, float] = {}
    with engine_backends(breaking_m) as built:
        inputs = draw_inputs(built["pybullet"], built["sapien"], SKILL, n, seed)
        for engine in ENGINES:
            table = np.zeros((n, 1 + len(shifts_mm)), dtype=bool)
            start = time.process_time()
            for index, (context, control) in enumerate(inputs):
                trial_seed = seed * 100_000 + index
                for j, shift in enumerate((0.0, *shifts_mm)):
                    moved = shifted_control(context, control, shift / 1000.0)
                    record = run_trial(built[engine], engine, SKILL, context, moved, trial_seed)
                    table[index, j] = record["error"] is None and is_success(record)
                if progress:
                    print(f"\r{engine}: {index + 1}/{n}", end="", file=sys.stderr, flush=True)
            if progress:
                print(file=sys.stderr)
            labels[engine] = table
            cpu[engine] = (time.process_time() - start) / (n * table.shape[1])
    return {
        "skill": SKILL, "trials": n, "seed": seed, "shifts_mm": list(shifts_mm),
        "physics_versions": {e: setting_version(e, SKILL) for e in ENGINES},
        "pybullet_contact_breaking_m": (built["pybullet"].world_config(SKILL)  # type: ignore[attr-defined]
                                        .contact_breaking_threshold),
        "what_if": breaking_m is not None,
        "cpu_s_per_trial": cpu, "machine": platform.platform(),
        "engines": {e: engine_summary(labels[e], shifts_mm) for e in ENGINES},
        "cross": cross_summary(labels["pybullet"], labels["sapien"]),
    }


def _fmt(r: dict) -> str:
    if not r["n"]:
        return "   (none)"
    low, high = r["wilson95"]
    return f"{r['count']:>3}/{r['n']:<3} {r['rate']:.3f} ({low:.3f}-{high:.3f})"


def print_table(summary: dict) -> None:
    shifts = ", ".join(f"{s:+g}" for s in summary["shifts_mm"])
    breaking = summary["pybullet_contact_breaking_m"]
    marker = ", what-if" if summary["what_if"] else ""
    what_if = f" (PyBullet contact breaking {breaking} m{marker})"
    print(f"3D push, {summary['trials']} inputs, pad shifted by {shifts} mm{what_if}")
    print(f"{'engine':<9} {'robust (Wilson 95%)':<30} flips per shift (mm)")
    for engine, s in summary["engines"].items():
        flips = "  ".join(f"{k}: {v}" for k, v in s["flips_per_shift"].items())
        print(f"{engine:<9} {_fmt(s['robust']):<30} {flips}")
    cross = summary["cross"]
    print("PyBullet vs SAPIEN agreement")
    for name, key in (("all inputs (as drawn)", "agreement_all"),
                      ("robust on both", "agreement_robust_on_both"),
                      ("robust on PyBullet", "agreement_robust_on_pybullet"),
                      ("majority labels", "agreement_majority")):
        print(f"  {name:<24} {_fmt(cross[key])}")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=200, help="inputs (the row's first N)")
    parser.add_argument("--seed", type=int, default=0, help="the row's seed")
    parser.add_argument("--shifts-mm", type=float, nargs="+", default=list(DEFAULT_SHIFTS_MM),
                        help="sideways pad shifts in millimetres")
    parser.add_argument("--pybullet-breaking-m", type=float, default=None, metavar="M",
                        help="what-if: PyBullet's push world's contact breaking threshold in "
                             "metres (shipped 0.02, Bullet's default; the bead worlds' 0.004)")
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "push_sensitivity.json")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")
    args = parser.parse_args(argv)
    if args.trials < 1:
        parser.error("--trials must be at least 1")
    if any(not np.isfinite(s) or s == 0.0 or abs(s) > 5.0 for s in args.shifts_mm):
        parser.error("--shifts-mm must be non-zero and at most 5 mm in size")
    breaking = args.pybullet_breaking_m
    if breaking is not None and not (np.isfinite(breaking) and 0.0 < breaking <= 0.1):
        parser.error("--pybullet-breaking-m must be in (0, 0.1] metres")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    summary = measure(args.trials, args.seed, tuple(args.shifts_mm), not args.quiet,
                      args.pybullet_breaking_m)
    print_table(summary)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    partial = args.out.with_suffix(".json.tmp")
    partial.write_text(json.dumps(summary, indent=1))
    partial.replace(args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
