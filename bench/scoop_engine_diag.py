"""Diagnose PyBullet vs SAPIEN scoop disagreements: per trial, both engines' measured spoon
capacity, beads in the spoon over time, where the beads end up.

Reads the ``3d-scoop-engine`` pairs from a ``bench/fidelity.py`` cache, picks the inputs
whose labels disagree (or ``--indices``), re-runs each on both engines with a recording
physics wrapper and writes one JSON line per (input, engine) to ``--out``.

    OMP_NUM_THREADS=1 .venv/bin/python bench/scoop_engine_diag.py \
        --cache docs/results/fidelity/engine_trials_v2.jsonl \
        --out docs/results/fidelity/scoop_diag.jsonl
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.pybullet.skills.physics import BulletTrialPhysics
from ltamp_cli.backends.pybullet.world import PhysicsWorld
from ltamp_cli.backends.sapien.skills import SapienTrialPhysics
from ltamp_cli.backends.sapien.world import SapienWorld, SapienWorldConfig
from ltamp_cli.backends.skills3d.physics import contained_mask
from ltamp_cli.backends.skills3d.scoop import run_scoop


@dataclass
class Recorder:
    """Delegates to an engine's trial physics and remembers the last tool and beads."""

    inner: Any
    tools: list[Any] = field(default_factory=list)
    beads: list[Any] = field(default_factory=list)
    series: list[tuple[int, int]] = field(default_factory=list)
    every: int = 24

    @property
    def time_step(self) -> float:
        return float(self.inner.time_step)

    def reset(self) -> None:
        self.inner.reset()

    def steps_for(self, seconds: float) -> int:
        return int(self.inner.steps_for(seconds))

    def add_body(self, geometry: Any, material: Any, role: Any, *args: Any) -> Any:
        body = self.inner.add_body(geometry, material, role, *args)
        if role == "tool":
            self.tools.append(body)
        return body

    def spawn_beads_in(self, container: Any, spec: Any, rng: np.random.Generator) -> Any:
        beads = self.inner.spawn_beads_in(container, spec, rng)
        self.beads.append(beads)
        return beads

    def _record(self, step: int) -> None:
        if step % self.every == 0 and len(self.beads) >= 2:
            n = int(contained_mask(self.tools[-1], self.beads[-1].positions()).sum())
            self.series.append((step, n))

    def follow(self, tool: Any, path: Any, on_step: Any = None, step_offset: int = 0) -> int:
        return int(self.inner.follow(tool, path, self._record, step_offset))

    def hold(self, tool: Any, position: Any, quaternion: Any, steps: int, on_step: Any = None,
             step_offset: int = 0) -> int:
        return int(self.inner.hold(tool, position, quaternion, steps, self._record,
                                   step_offset))


def engine_physics(name: str, **config: Any) -> Any:
    if name == "pybullet":
        return BulletTrialPhysics(PhysicsWorld())
    return SapienTrialPhysics(SapienWorld(SapienWorldConfig(**config)))


def disagreeing(cache: Path) -> list[dict]:
    rows: dict[int, dict[str, dict]] = {}
    for line in cache.open():
        record = json.loads(line)
        if record["skill"] == "scoop" and record["setting"] in ("pybullet", "sapien"):
            rows.setdefault(record["seed"], {})[record["setting"]] = record
    out = []
    for seed, pair in sorted(rows.items()):
        if len(pair) == 2:
            labels = [p["valid"] and p["score"] > 0 for p in pair.values()]
            out.append({"index": seed, "context": pair["pybullet"]["context"],
                        "control": pair["pybullet"]["control"],
                        "agree": labels[0] == labels[1],
                        "scores": {k: v["score"] for k, v in pair.items()}})
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--indices", type=int, nargs="*", default=None)
    parser.add_argument("--engines", nargs="*", default=["pybullet", "sapien"])
    args = parser.parse_args(argv)
    inputs = disagreeing(args.cache)
    chosen = ([i for i in inputs if i["index"] in set(args.indices)] if args.indices
              else [i for i in inputs if not i["agree"]])
    engines = {name: engine_physics(name) for name in args.engines}
    for item in chosen:
        for name, physics in engines.items():
            recorder = Recorder(physics)
            start = time.process_time()
            result = run_scoop(recorder, np.array(item["context"]), np.array(item["control"]),
                               item["index"])  # type: ignore[arg-type]
            row = {"index": item["index"], "engine": name, "score": result.score,
                   "cached_scores": item["scores"], "info": dict(result.info),
                   "series": recorder.series, "cpu_s": time.process_time() - start}
            with args.out.open("a") as out:
                out.write(json.dumps(row) + "\n")
            info = result.info
            print(item["index"], name, f"{result.score:+.3f}", info.get("spoon_capacity"),
                  info.get("beads_in_spoon_end"), [n for _, n in recorder.series][-8:],
                  file=sys.stderr, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
