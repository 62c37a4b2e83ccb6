"""How stable is a setting's label under a sub-millimetre change of the control? (any skill)

A fidelity row (:mod:`bench.fidelity`) asks a fast setting to agree with a reference
setting's labels (``valid and score > 0``) on >= 95 % of random inputs. If the reference's
own label flips when a control moves by a tenth of a millimetre, no setting can be expected
to agree with it more often than it agrees with itself, and the rule has to be read against
that ceiling. :mod:`bench.push_sensitivity` measured it for the push (60 s CPU, no cache);
this does the same for any skill on a committed ``--inputs`` file of a fidelity row, with a
resumable cache, since a bead trial costs seconds (the 3D scoop: 6-9 s CPU on PyBullet).

Each chosen input runs under each ``--settings`` setting as drawn (the fidelity row's own
trial: same context, control and trial seed ``seed * 100000 + index``, so it is read from
the row's cache, ``--read-cache``) and once per ``--shifts`` entry ``DIM:MM`` (the control
``DIM`` moved by ``MM`` millimetres; a control in "× <context length>" units moves by
``MM / that length``; ``DIM:MM/CTX`` names the context length when the unit does not).
An input is *robust* under a setting when all its runs give the same label; a shift's
*self-agreement* is the share of inputs whose shifted label equals the label as drawn.

Which inputs (CPU is scarce, so a subset is allowed and said): ``--disagreeing A B`` takes
every input of the first ``--trials`` whose cached labels under settings A and B differ;
``--random K`` adds K inputs drawn uniformly without replacement from the first
``--trials`` (``numpy.random.default_rng(--subset-seed)``; without ``--random`` all of them).
The disagreeing inputs are run first, then the random ones in their drawn order, so a run
stopped early still summarises a prefix of each group. Rates are given on the random group
(an unbiased sample of the row's inputs) and on the disagreeing group separately, never
pooled. With no shifts the script only runs (and compares) the settings' labels as drawn,
e.g. to screen an intermediate setting on the disagreeing inputs plus a random subset.

The committed 3D scoop run (issue #20/#21: PyBullet 5 vs 50 solver iterations, 2 shards):

    OMP_NUM_THREADS=1 .venv/bin/python bench/label_stability.py \
        --inputs docs/results/fidelity/engine_scoop_inputs.json --trials 200 \
        --read-cache docs/results/fidelity/engine_scoop_bed_trials.jsonl \
        --cache docs/results/fidelity/scoop_stability_trials.jsonl \
        --settings pybullet-solver-50 pybullet --run pybullet-solver-50 pybullet \
        --disagreeing pybullet pybullet-solver-50 --random 60 \
        --shifts scoop_z:-0.1 scoop_z:+0.1 --shard 0/2 \
        --out docs/results/fidelity/scoop_stability.json

``--run`` names the settings whose missing trials this process runs (none: only summarise).
"""

from __future__ import annotations

import argparse
import json
import platform
import re
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench.fidelity import (
    RESULTS_DIR,
    SETTINGS,
    append_record,
    backends,
    is_success,
    load_cache,
    run_trial,
    trial_key,
    wilson_interval,
)
from ltamp_cli.backends.protocol import SkillSpec

#: ``DIM:MM`` or ``DIM:MM/CTX`` (a control name, a signed millimetre shift, a context name).
_SHIFT = re.compile(r"^(?P<dim>[A-Za-z_]\w*):(?P<mm>[+-]?\d+(\.\d*)?([eE][+-]?\d+)?)"
                    r"(/(?P<ctx>[A-Za-z_]\w*))?$")
#: Largest shift accepted (mm): beyond it the question is no longer "noise".
MAX_SHIFT_MM = 5.0


@dataclass(frozen=True)
class Shift:
    """Move control ``dim`` by ``mm`` millimetres (``per``: the context length its unit is a
    fraction of, ``None`` for a control in metres)."""

    dim: str
    mm: float
    per: str | None

    @property
    def label(self) -> str:
        return f"{self.dim}:{self.mm:+g}"


def parse_shift(text: str, spec: SkillSpec) -> Shift:
    """A ``--shifts`` entry checked against ``spec``; ``ValueError`` says what is wrong."""
    match = _SHIFT.match(text)
    if match is None:
        raise ValueError(f"shift {text!r}: expected DIM:MM or DIM:MM/CONTEXT, e.g. scoop_z:+0.1")
    dim, mm = match["dim"], float(match["mm"])
    if dim not in spec.control.names:
        raise ValueError(f"shift {text!r}: {spec.name} has no control {dim!r} "
                         f"(controls: {', '.join(spec.control.names)})")
    if mm == 0.0 or abs(mm) > MAX_SHIFT_MM:
        raise ValueError(f"shift {text!r}: MM must be non-zero and at most {MAX_SHIFT_MM} mm")
    unit = (spec.control.units or ("",) * spec.control.dim)[spec.control.names.index(dim)]
    per = match["ctx"]
    if per is None and unit.startswith("×"):
        per = unit.lstrip("× ").strip().replace(" ", "_")
    elif per is None and unit != "m":
        raise ValueError(f"shift {text!r}: control {dim!r} is in {unit!r}, not metres")
    if per is not None and per not in spec.context.names:
        raise ValueError(f"shift {text!r}: {spec.name} has no context length {per!r} "
                         f"(context: {', '.join(spec.context.names)}); name it as DIM:MM/CTX")
    return Shift(dim, mm, per)


def shifted_control(spec: SkillSpec, context: np.ndarray, control: np.ndarray,
                    shift: Shift) -> np.ndarray:
    """``control`` ``(d_control,)`` with ``shift.dim`` moved by ``shift.mm`` mm (divided by
    the context length ``shift.per`` (m) for a control in fractions of it); a copy."""
    moved = np.array(control, dtype=float)
    metres = shift.mm / 1000.0
    scale = 1.0 if shift.per is None else float(context[spec.context.names.index(shift.per)])
    moved[spec.control.names.index(shift.dim)] += metres / scale
    return moved


def load_inputs(path: Path, n: int) -> tuple[str, int, np.ndarray]:
    """The skill, seed and first ``n`` inputs ``(n, d_context + d_control)`` of a fidelity
    row's ``--inputs`` file; ``ValueError`` if it has fewer."""
    stored = json.loads(path.read_text())
    inputs = np.asarray(stored["inputs"], dtype=float)
    if len(inputs) < n:
        raise ValueError(f"{path}: holds {len(inputs)} inputs, --trials asks for {n}")
    return str(stored["skill"]), int(stored["seed"]), inputs[:n]


def choose_inputs(n: int, disagreeing: list[int], k_random: int | None, subset_seed: int
                  ) -> tuple[list[int], list[int]]:
    """``(disagreeing, random)`` input indices: the given disagreeing ones (sorted) and
    ``k_random`` drawn uniformly without replacement from ``range(n)`` in drawn order
    (``None``: all ``n`` in order). The groups may overlap: each is summarised alone."""
    if k_random is None:
        chosen = list(range(n))
    else:
        chosen = [int(i) for i in np.random.default_rng(subset_seed).permutation(n)[:k_random]]
    return sorted(set(disagreeing)), chosen


def rate(count: int, n: int) -> dict:
    """``count / n`` with its 95 % Wilson interval."""
    low, high = wilson_interval(count, n)
    return {"count": count, "n": n, "rate": count / n if n else None, "wilson95": [low, high]}


def stability(labels: np.ndarray, shifts: list[str]) -> dict:
    """Stability of one setting's labels ``(n, 1 + k)`` (column 0 as drawn, then one column
    per shift): robust inputs, and per shift the inputs whose label stays (self-agreement)."""
    if labels.shape[1] == 1:
        return {"success_as_drawn": rate(int(labels[:, 0].sum()), len(labels))}
    robust = (labels == labels[:, :1]).all(axis=1)
    same = labels[:, 1:] == labels[:, :1]  # (n, k)
    return {
        "success_as_drawn": rate(int(labels[:, 0].sum()), len(labels)),
        "robust": rate(int(robust.sum()), len(labels)),
        "self_agreement": {s: rate(int(same[:, j].sum()), len(labels))
                           for j, s in enumerate(shifts)},
        "self_agreement_mean": float(same.mean()) if same.size else None,
    }


def agreement(fast: np.ndarray, reference: np.ndarray, ref_robust: np.ndarray | None) -> dict:
    """Agreement of two settings' labels as drawn (bool ``(n,)`` each), and on the inputs
    whose reference label is robust (``ref_robust``, bool ``(n,)``) when known."""
    agree = fast == reference
    out = {"all": rate(int(agree.sum()), len(agree)),
           "fast_only": int((fast & ~reference).sum()),
           "reference_only": int((~fast & reference).sum())}
    if ref_robust is not None:
        out["reference_robust"] = rate(int(agree[ref_robust].sum()), int(ref_robust.sum()))
    return out


@dataclass
class Plan:
    """What one process does: the row's inputs and which trials to run or read."""

    spec: SkillSpec
    seed: int
    inputs: np.ndarray  # (n, d_context + d_control)
    settings: list[str]
    run: frozenset[str]
    shifts: list[Shift]
    #: Cache-key names to read a setting's trials under instead of today's
    #: (:func:`bench.fidelity.trial_key`), e.g. ``{"pybullet": "pybullet@v1"}`` for trials
    #: simulated before a physics revision (read only: such trials cannot be run again).
    key_names: Mapping[str, str] | None = None

    def split(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        row = self.inputs[index]
        return row[:self.spec.context.dim], row[self.spec.context.dim:]

    def controls(self, index: int) -> list[np.ndarray]:
        """The input's control as drawn, then once per shift."""
        context, control = self.split(index)
        return [control, *(shifted_control(self.spec, context, control, s)
                           for s in self.shifts)]

    def key(self, setting: str, index: int, control: np.ndarray) -> str:
        context, _ = self.split(index)
        seed = self.seed * 100_000 + index
        if self.key_names and setting in self.key_names:
            values = ",".join(f"{v:.12g}" for v in (*context, *control))
            return f"{self.key_names[setting]}|{self.spec.name}|{seed}|{values}"
        return trial_key(setting, self.spec.name, context, control, seed)


def run_missing(plan: Plan, order: list[int], shard: tuple[int, int], cache_path: Path,
                cache: dict[str, dict], read_caches: list[Path], progress: bool) -> None:
    """Run this shard's missing trials of ``plan.run`` on the inputs ``order`` (position
    ``p`` belongs to shard ``p % m``), appending each to ``cache_path`` as it finishes."""
    mine = [index for p, index in enumerate(order) if p % shard[1] == shard[0]]
    if not mine or not plan.run:
        return
    with backends(tuple(s for s in plan.settings if s in plan.run)) as built:
        for done, index in enumerate(mine):
            context, _ = plan.split(index)
            for setting, backend in built.items():
                for control in plan.controls(index):
                    key = plan.key(setting, index, control)
                    if key not in cache:  # the row's own runs or another shard may have it
                        for path in (cache_path, *read_caches):
                            cache.update(load_cache(path))
                    if key in cache:
                        continue
                    seed = plan.seed * 100_000 + index
                    record = {"key": key, "setting": setting, "skill": plan.spec.name,
                              "seed": seed, "context": context.tolist(),
                              "control": control.tolist(),
                              **run_trial(backend, setting, plan.spec.name, context, control,
                                          seed)}
                    append_record(cache_path, record)
                    cache[key] = record
            if progress:
                print(f"\rinputs {done + 1}/{len(mine)}", end="", file=sys.stderr, flush=True)
    if progress:
        print(file=sys.stderr)


def labels_of(plan: Plan, cache: dict[str, dict], setting: str, indices: list[int]
              ) -> tuple[list[int], np.ndarray, list[float]]:
    """The inputs of ``indices`` with every run of ``setting`` cached and without error,
    their labels ``(n, 1 + k)`` and the CPU seconds of those runs."""
    kept, rows, cpu = [], [], []
    for index in indices:
        records = [cache.get(plan.key(setting, index, c)) for c in plan.controls(index)]
        if any(r is None or r["error"] is not None for r in records):
            continue
        kept.append(index)
        rows.append([is_success(r) for r in records])
        cpu.extend(float(r["cpu_s"]) for r in records)
    return kept, np.array(rows, dtype=bool).reshape(len(kept), 1 + len(plan.shifts)), cpu


def summarise(plan: Plan, cache: dict[str, dict], groups: dict[str, list[int]],
              compare: list[tuple[str, str]]) -> dict:
    """Per group of inputs: each setting's stability, and each compared pair's agreement
    (as drawn, and on the inputs where the reference is robust), on the inputs where every
    setting involved has all its runs."""
    names = [s.label for s in plan.shifts]
    out: dict = {}
    for group, indices in groups.items():
        per_setting = {s: labels_of(plan, cache, s, indices) for s in plan.settings}
        block: dict = {"inputs": len(indices), "settings": {}}
        for setting, (kept, labels, cpu) in per_setting.items():
            block["settings"][setting] = {
                "measured": len(kept), "cpu_s_per_trial": float(np.mean(cpu)) if cpu else None,
                **stability(labels, names),
                "unstable_inputs": [i for i, row in zip(kept, labels, strict=True)
                                    if not (row == row[0]).all()],
                "labels": {str(i): row.astype(int).tolist()
                           for i, row in zip(kept, labels, strict=True)}}
        block["pairs"] = {}
        for fast, reference in compare:
            common = sorted(set(per_setting[fast][0]) & set(per_setting[reference][0]))
            if not common:
                continue
            f = _rows(per_setting[fast], common)
            r = _rows(per_setting[reference], common)
            robust = (r == r[:, :1]).all(axis=1) if plan.shifts else None
            block["pairs"][f"{fast} vs {reference}"] = agreement(f[:, 0], r[:, 0], robust)
        out[group] = block
    return out


def _rows(measured: tuple[list[int], np.ndarray, list[float]], indices: list[int]
          ) -> np.ndarray:
    kept, labels, _ = measured
    where = {index: j for j, index in enumerate(kept)}
    return labels[[where[i] for i in indices]]


def _fmt(r: dict) -> str:
    if not r["n"]:
        return "(none)"
    low, high = r["wilson95"]
    return f"{r['count']}/{r['n']} {r['rate']:.3f} ({low:.3f}-{high:.3f})"


def print_table(summary: dict) -> None:
    shifts = ", ".join(summary["shifts"]) or "none (labels as drawn only)"
    print(f"{summary['skill']}: first {summary['trials']} inputs, shifts {shifts}")
    for group, block in summary["groups"].items():
        print(f"[{group}: {block['inputs']} inputs]")
        for setting, s in block["settings"].items():
            line = f"  {setting:<20} measured {s['measured']:>3}"
            if "robust" in s:
                line += f"  robust {_fmt(s['robust'])}"
                line += "  self-agreement " + "  ".join(
                    f"{k} {_fmt(v)}" for k, v in s["self_agreement"].items())
            print(line + f"  success {_fmt(s['success_as_drawn'])}")
        for pair, a in block["pairs"].items():
            extra = (f"  on reference-robust {_fmt(a['reference_robust'])}"
                     if "reference_robust" in a else "")
            print(f"  {pair:<36} agree {_fmt(a['all'])}  f-only {a['fast_only']} "
                  f"r-only {a['reference_only']}{extra}")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--inputs", type=Path, required=True, metavar="JSON",
                        help="a fidelity row's --inputs file (skill, seed, inputs)")
    parser.add_argument("--trials", type=int, default=200, help="the row's first N inputs")
    parser.add_argument("--settings", nargs="+", required=True, choices=sorted(SETTINGS),
                        metavar="SETTING", help="settings to summarise")
    parser.add_argument("--run", nargs="*", default=[], choices=sorted(SETTINGS),
                        metavar="SETTING", help="settings whose missing trials to run")
    parser.add_argument("--shifts", nargs="*", default=[], metavar="DIM:MM[/CTX]",
                        help="control shifts in millimetres, e.g. scoop_z:-0.1 scoop_z:+0.1")
    parser.add_argument("--disagreeing", nargs=2, default=None, metavar=("A", "B"),
                        choices=sorted(SETTINGS),
                        help="include every input whose cached labels under A and B differ")
    parser.add_argument("--random", type=int, default=None, metavar="K",
                        help="a uniform random K of the inputs (default: all)")
    parser.add_argument("--subset-seed", type=int, default=0)
    parser.add_argument("--cache", type=Path, required=True, help="JSONL the new trials go to")
    parser.add_argument("--read-cache", type=Path, nargs="*", default=[],
                        help="more JSONL trial caches to read (e.g. the fidelity row's)")
    parser.add_argument("--shard", default="0/1", metavar="K/M")
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "label_stability.json")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")
    args = parser.parse_args(argv)
    if args.trials < 1:
        parser.error("--trials must be at least 1")
    if args.random is not None and not 1 <= args.random <= args.trials:
        parser.error("--random must be in [1, --trials]")
    if not set(args.run) <= set(args.settings):
        parser.error("--run: every setting run must also be in --settings")
    if args.disagreeing is not None and not set(args.disagreeing) <= set(args.settings):
        parser.error("--disagreeing: both settings must be in --settings")
    match = re.fullmatch(r"(\d+)/(\d+)", args.shard)
    if match is None or not int(match[1]) < int(match[2]):
        parser.error("--shard must be K/M with 0 <= K < M")
    args.shard = (int(match[1]), int(match[2]))
    if not args.inputs.is_file():
        parser.error(f"--inputs: no such file {args.inputs}")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        skill, seed, inputs = load_inputs(args.inputs, args.trials)
        spec = _spec_of(args.settings[0], skill)
        shifts = [parse_shift(text, spec) for text in args.shifts]
    except (ValueError, KeyError, json.JSONDecodeError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    plan = Plan(spec, seed, inputs, list(dict.fromkeys(args.settings)), frozenset(args.run),
                shifts)
    cache: dict[str, dict] = {}
    for path in (args.cache, *args.read_cache):
        cache.update(load_cache(path))
    disagreeing: list[int] = []
    if args.disagreeing is not None:
        a, b = args.disagreeing
        drawn = [[cache.get(plan.key(s, i, plan.split(i)[1])) for s in (a, b)]
                 for i in range(args.trials)]
        disagreeing = [i for i, (ra, rb) in enumerate(drawn)
                       if ra is not None and rb is not None and ra["error"] is None
                       and rb["error"] is None and is_success(ra) != is_success(rb)]
    bad, chosen = choose_inputs(args.trials, disagreeing, args.random, args.subset_seed)
    order = list(dict.fromkeys([*bad, *chosen]))
    args.cache.parent.mkdir(parents=True, exist_ok=True)
    run_missing(plan, order, args.shard, args.cache, cache, list(args.read_cache),
                not args.quiet)
    for path in (args.cache, *args.read_cache):  # the other shards' trials too
        cache.update(load_cache(path))
    settings = plan.settings
    compare = [(f, r) for j, r in enumerate(settings) for f in settings[j + 1:]]
    if args.disagreeing is not None:
        compare = [tuple(args.disagreeing)] + [p for p in compare  # type: ignore[list-item]
                                               if set(p) != set(args.disagreeing)]
    groups = {"random": chosen, **({"disagreeing": bad} if args.disagreeing else {})}
    summary = {"skill": skill, "trials": args.trials, "seed": seed,
               "shifts": [s.label for s in shifts],
               "subset": {"random": args.random, "subset_seed": args.subset_seed,
                          "disagreeing": list(args.disagreeing or [])},
               "machine": platform.platform(),
               "groups": summarise(plan, cache, groups, compare)}
    print_table(summary)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    partial = args.out.with_suffix(".json.tmp")
    partial.write_text(json.dumps(summary, indent=1))
    partial.replace(args.out)
    print(f"wrote {args.out}")
    return 0


def _spec_of(setting: str, skill: str) -> SkillSpec:
    """The skill's spec from ``setting``'s backend (``KeyError`` for an unknown skill)."""
    with backends((setting,)) as built:
        return built[setting].skills()[skill]


if __name__ == "__main__":
    raise SystemExit(main())
