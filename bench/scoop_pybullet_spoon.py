"""Does PyBullet's re-placed dynamic spoon shed the scooped spoonful? (issue #21 diagnosis)

PyBullet has no kinematic bodies with velocity, so the scoop's spoon is a dynamic body put
at its path pose before every step (:mod:`ltamp_cli.backends.pybullet.skills.physics`).
Within a step it falls under gravity (g·dt² ≈ 0.17 mm at 1/240 s) and is pushed by its
load, and the next placement teleports it back into the beads. This re-runs scoop inputs
of a stored-inputs file (``bench/fidelity.py --inputs``; trial seed = index) on PyBullet
with the spoon changed in one way and writes one JSON line per trial (capacity, spoonful,
score, the cached PyBullet score) to ``--out`` (resumable):

* ``none``: as shipped (a check that the cache reproduces);
* ``heavy``: the spoon's mass × 1000 (its load no longer pushes it; gravity still does);
* ``weightless``: an upward force of the spoon's weight every step (no gravity sag; the
  load still pushes it);
* ``solver50``: the spoon as shipped, the solver at the reference implementation's 50
  iterations (shipped: 5), so bead-on-bead contacts are solved stiffly.

If the spoonful grows towards SAPIEN's with either, that part of the placement is what makes
PyBullet spill more during the lift than SAPIEN's kinematic spoon.

    OMP_NUM_THREADS=1 .venv/bin/python bench/scoop_pybullet_spoon.py --variant heavy \\
        --inputs docs/results/fidelity/engine_scoop_inputs.json \\
        --cache docs/results/fidelity/engine_scoop_bed_trials.jsonl \\
        --indices 0 6 12 --out docs/results/fidelity/scoop_pybullet_spoon.jsonl

``--summary CAPACITIES SAPIEN_RERUNS`` prints per variant the mean capacity and spoonful
next to shipped PyBullet's and SAPIEN v3's on the same inputs (:func:`summarise`):

    .venv/bin/python bench/scoop_pybullet_spoon.py --inputs \
        docs/results/fidelity/engine_scoop_inputs.json \
        --cache docs/results/fidelity/engine_scoop_bed_trials.jsonl \
        --out docs/results/fidelity/scoop_pybullet_spoon.jsonl --summary \
        docs/results/fidelity/scoop_capacity_pybullet_borderline.jsonl \
        docs/results/fidelity/scoop_fit_engine_settings.jsonl
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pybullet as p

from bench.fidelity import load_cache, trial_key
from ltamp_cli.backends.kitchenware_geometry import KitchenwareGeometry
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial, KitchenwareBody
from ltamp_cli.backends.pybullet.skills.physics import BulletTrialPhysics
from ltamp_cli.backends.pybullet.world import PhysicsWorld, WorldConfig, skill_world_config
from ltamp_cli.backends.skills3d.physics import IDENTITY_QUAT, BodyRole, StepCallback
from ltamp_cli.backends.skills3d.scoop import SCOOP_TAU, run_scoop

VARIANTS = ("none", "heavy", "weightless", "solver50")
#: The Kitchen3D reference implementation's PyBullet solver iterations (field facts).
REFERENCE_SOLVER_ITERATIONS = 50
HEAVY_FACTOR = 1000.0
GRAVITY_M_S2 = 9.81


@dataclass(frozen=True, eq=False)
class SpoonVariantPhysics(BulletTrialPhysics):
    """:class:`BulletTrialPhysics` whose carried spoon is ``variant`` (see the module)."""

    variant: str = "heavy"
    #: The carried spoon of the current scene: (PyBullet id, mass kg); empty until added.
    spoon: list[tuple[int, float]] = field(default_factory=list)

    def reset(self) -> None:
        self.spoon.clear()
        super().reset()

    def add_body(self, geometry: KitchenwareGeometry, material: BodyMaterial, role: BodyRole,
                 position: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
                 quaternion: Sequence[float] | np.ndarray = IDENTITY_QUAT) -> KitchenwareBody:
        carried = role == "tool" and geometry.kind == "spoon"
        if carried and self.variant == "heavy":
            material = replace(material, mass=material.mass * HEAVY_FACTOR)
        body = super().add_body(geometry, material, role, position, quaternion)
        if carried:
            self.spoon[:] = [(body.body, material.mass)]
        return body

    def run_steps(self, n: int, before_step: Callable[[int], None] | None,
                  on_step: StepCallback | None, step_offset: int = 0) -> int:
        """The parent's steps; ``weightless``: after each placement, the spoon's weight
        pushes it up (Bullet clears external forces after every step)."""
        if self.variant != "weightless":
            return super().run_steps(n, before_step, on_step, step_offset)
        client = self.world.client

        def place_and_lift(i: int) -> None:
            if before_step is not None:
                before_step(i)
            for uid, mass in self.spoon:
                centre = p.getBasePositionAndOrientation(uid, physicsClientId=client)[0]
                p.applyExternalForce(uid, -1, [0.0, 0.0, mass * GRAVITY_M_S2], centre,
                                     p.WORLD_FRAME, physicsClientId=client)

        return super().run_steps(n, place_and_lift, on_step, step_offset)


def _fraction(score: float, valid: bool) -> float:
    """The clipped fraction of capacity of a scoop score (0 for an invalid trial)."""
    if not valid:
        return 0.0
    return (score + 1.0) * SCOOP_TAU if score <= 0 else SCOOP_TAU + score * (1.0 - SCOOP_TAU)


def summarise(lines: Path, capacities: Path, sapien_reruns: Path) -> list[dict]:
    """Per variant, on its inputs that also have PyBullet's shipped capacity
    (``scoop_engine_diag.py --capacity`` lines) and a SAPIEN v3 re-run (``--rerun`` lines with
    ``cfg`` ``{}``): mean capacity and spoonful (beads) of the variant, of shipped PyBullet
    (spoonful = clipped fraction × capacity) and of SAPIEN v3, and labels (score > 0)
    agreeing with SAPIEN v3."""
    capacity = {json.loads(line)["index"]: json.loads(line)["capacity"]
                for line in capacities.open()}
    sapien = {}
    for line in sapien_reruns.open():
        row = json.loads(line)
        if row["cfg"] == {}:
            sapien[row["index"]] = row
    by_variant: dict[str, list[dict]] = {}
    for line in lines.open():
        row = json.loads(line)
        if row["index"] in capacity and row["index"] in sapien:
            by_variant.setdefault(row["variant"], []).append(row)
    out = []
    for variant, rows in sorted(by_variant.items()):
        shipped_spoon = [_fraction(r["cached_pybullet_score"], True) * capacity[r["index"]]
                         for r in rows]
        out.append({
            "variant": variant, "inputs": len(rows),
            "capacity": float(np.mean([r["info"]["spoon_capacity"] for r in rows])),
            "capacity_pybullet": float(np.mean([capacity[r["index"]] for r in rows])),
            "capacity_sapien_v3": float(np.mean(
                [sapien[r["index"]]["info"]["spoon_capacity"] for r in rows])),
            "spoonful": float(np.mean([r["info"]["beads_in_spoon_end"] for r in rows])),
            "spoonful_pybullet": float(np.mean(shipped_spoon)),
            "spoonful_sapien_v3": float(np.mean(
                [sapien[r["index"]]["info"]["beads_in_spoon_end"] for r in rows])),
            "labels_agree_sapien_v3": sum(
                (r["valid"] and r["score"] > 0)
                == (sapien[r["index"]]["valid"] and sapien[r["index"]]["score"] > 0)
                for r in rows),
            "labels_agree_pybullet": sum(
                (r["valid"] and r["score"] > 0) == (r["cached_pybullet_score"] > 0)
                for r in rows),
        })
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variant", choices=VARIANTS)
    parser.add_argument("--summary", nargs=2, type=Path, default=None,
                        metavar=("CAPACITIES", "SAPIEN_RERUNS"),
                        help="summarise --out instead of running (:func:`summarise`)")
    parser.add_argument("--inputs", type=Path, required=True)
    parser.add_argument("--cache", type=Path, required=True)
    parser.add_argument("--indices", type=int, nargs="+", default=[])
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    if args.summary is not None:
        for row in summarise(args.out, *args.summary):
            print(json.dumps(row))
        return 0
    if args.variant is None:
        parser.error("--variant is required to run trials")
    stored = json.loads(args.inputs.read_text())["inputs"]
    cache = load_cache(args.cache)
    done = set()
    if args.out.exists():
        for line in args.out.open():
            row = json.loads(line)
            done.add((row["index"], row["variant"]))
    base = WorldConfig(solver_iterations=REFERENCE_SOLVER_ITERATIONS) if (
        args.variant == "solver50") else None
    physics = SpoonVariantPhysics(PhysicsWorld(skill_world_config("scoop", base)), args.variant)
    for index in args.indices:
        if (index, args.variant) in done:
            continue
        row = np.asarray(stored[index], dtype=float)
        context, control = row[:4], row[4:]
        start = time.process_time()
        result = run_scoop(physics, context, control, index)
        old = cache.get(trial_key("pybullet", "scoop", context, control, index))
        record = {"index": index, "variant": args.variant, "score": float(result.score),
                  "valid": bool(result.valid),
                  "cached_pybullet_score": None if old is None else old["score"],
                  "info": {k: v for k, v in result.info.items()
                           if isinstance(v, int | float | str | None)},
                  "cpu_s": time.process_time() - start}
        with args.out.open("a") as out:
            out.write(json.dumps(record) + "\n")
        print(index, args.variant, f"{result.score:+.3f}", record["cached_pybullet_score"],
              result.info.get("spoon_capacity"), result.info.get("beads_in_spoon_end"),
              file=sys.stderr, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
