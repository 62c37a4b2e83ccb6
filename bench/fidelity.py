"""Fidelity of the fast simulation settings: do they change which controls succeed?

For each comparison row (a skill, a *fast* setting and a *reference* setting) this draws
``--trials`` (default 200) random inputs: a context from the skill's context distribution
and a control uniform in its box, redrawn until the pre-check of both settings accepts it.
Every input runs once under each setting with the same trial seed; a trial's label is
``valid and score > 0`` (success). The table gives each setting's success rate, the label
agreement with its 95 % Wilson interval (`wilson_interval`), the disagreements
by direction, the mean CPU seconds per trial of each setting, and whether the agreement
reaches ``--target`` (default 0.95).

Rows (``--rows``, default all):

* ``2d-pour-reference``: Box2D pour as shipped (``PourConfig()``: 100 particles, tilt
  0.25 rad/s, 10 s cap) vs the reference implementation's settings (``pour.REFERENCE``:
  500 particles, 0.1 rad/s, 30 s cap); ``2d-pour-particles`` and ``2d-pour-tilt`` change one
  of them only. Both carry the full cup from (−15, 0) to the pour pose first. (The 2D push
  has no fast setting: it runs as the reference defines it, in milliseconds.)
* ``2d-scoop-reference``: Box2D scoop as shipped (grains of radius 0.1) vs the reference
  implementation's grains (radius 0.05, four times as many for the same bed).
* ``3d-<skill>-engine`` (pour, scoop, push, stir): PyBullet vs SAPIEN, both as shipped.
* ``3d-scoop-placed-spoon``: PyBullet vs SAPIEN with the scoop's spoon as a placed dynamic
  body (``SapienWorldConfig.spoon_tool = "placed"``, issue #21; not shipped).
* ``3d-<skill>-solver``: PyBullet with 5 solver iterations vs 50 (the reference
  implementation's); pour, push and stir ship 5, the scoop ships 50 since issues #20/#21
  (its row compares ``pybullet-solver-5`` with ``pybullet-solver-50``).
* ``3d-<skill>-robot`` (pour, scoop, push, stir): PyBullet with the free-floating tool
  (fast) vs the Panda in the loop (``robot="panda"``: grasp with a force-limited
  constraint, IK + joint position control at the skill's timing; reach, arm collisions and
  slip fail). The summary adds the cost ratio (robot CPU / free CPU per trial), the
  robot's failure reasons, and the agreement on the inputs the robot carried out. The
  free-floating side of the scoop and push rows is the ``3d-<skill>-engine`` rows' PyBullet
  side (same inputs, seeds and keys: its records were copied into the robot cache).

Every trial is appended as one JSON line to ``--cache`` (default
``bench/results/fidelity_trials.jsonl``) as soon as it finishes; a rerun with the same
arguments reuses the trials already there, so a long run can be stopped and resumed. The
key of a 3D engine's trial carries that engine's physics version for the skill
(:func:`setting_version`: PyBullet's per-skill :func:`physics_version`, e.g. ``pybullet@v1``
for pour and scoop and ``pybullet@v1.1`` for the push since its world's 2 cm contact breaking
threshold; SAPIEN's per-skill version, ``sapien@v3``), so trials simulated before an engine
change are never reused, and a change to one skill's world leaves the other skills' cached
trials valid.
``--settings`` runs only the named settings' trials (the others are read from the cache
when present): a slow engine's side of a row can start before the other engine is final.
The summary is written to ``--out`` (default ``bench/results/fidelity.json``).

    OMP_NUM_THREADS=1 .venv/bin/python bench/fidelity.py --rows 3d-pour-engine
    OMP_NUM_THREADS=1 .venv/bin/python bench/fidelity.py --rows 2d-pour-reference --trials 50

The committed 3D engine rows (``--settings pybullet`` / ``--settings sapien`` in two
processes fill one side each; ``--settings`` naming none only summarises the cached pairs):

    OMP_NUM_THREADS=1 .venv/bin/python bench/fidelity.py --rows 3d-pour-engine \
        3d-push-engine 3d-scoop-engine --cache docs/results/fidelity/engine_trials_v2.jsonl \
        --out docs/results/fidelity/engine.json

The robot rows' committed runs (robot setup 1's pour row is kept in ``robot_v1.json``,
setup 2's in ``robot_pour_setup2.json``): pour and push with ``--trials 200``, scoop with
``--trials 100`` and stir with ``--trials 50`` (each resumable, two ``--shard``s for pour
and scoop), then the summary of the cached pairs (``--settings`` naming none runs nothing):

    OMP_NUM_THREADS=1 .venv/bin/python bench/fidelity.py --rows 3d-pour-robot \
        3d-scoop-robot 3d-push-robot 3d-stir-robot --trials 200 --settings \
        --cache docs/results/fidelity/robot_trials.jsonl \
        --out docs/results/fidelity/robot.json

The 3D push's rows in its goal parameterisation (context ``goal_x``, control ``travel``;
``engine.json``, ``solver_push.json`` and ``robot.json`` take their rows from the 600-input
summary; ``--trials 200`` gives ``push_goal.json``; about 2.5 CPU-minutes):

    OMP_NUM_THREADS=1 .venv/bin/python bench/fidelity.py --rows 3d-push-engine \
        3d-push-solver 3d-push-robot --trials 600 \
        --cache docs/results/fidelity/push_goal_trials.jsonl \
        --out docs/results/fidelity/push_goal_600.json

A skill that declares an outcome (the 3D push) keeps it in each trial record; its rows add
a goal sweep (:func:`goal_sweep`: labels recomputed from the recorded outcomes at
:data:`SWEEP_GOALS` goals per input) and the outcome differences
(:func:`outcome_differences`). With a rare success, agreement is high whatever the settings
do, so every row also counts the inputs where either / both settings succeed.

The 2D pour's committed run (resumable: the reference trials cost 10-15 s CPU each):

    OMP_NUM_THREADS=1 .venv/bin/python bench/fidelity.py --rows 2d-pour-reference \
        --trials 200 --cache docs/results/fidelity/pour_trials.jsonl \
        --out docs/results/fidelity/pour.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ltamp_cli.backends import SkillBackend, load_backend
from ltamp_cli.backends.box2d.backend import Kitchen2DBackend
from ltamp_cli.backends.box2d.skills.pour import REFERENCE, PourConfig
from ltamp_cli.backends.box2d.skills.scoop import reference_config as reference_scoop
from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.backends.pybullet.skills.robot import ROBOT_SETUP_VERSIONS
from ltamp_cli.backends.pybullet.world import physics_version as pybullet_physics_version
from ltamp_cli.backends.sapien.world import physics_version as sapien_physics_version
from ltamp_cli.learning.metrics import wilson_interval

RESULTS_DIR = Path(__file__).resolve().parent / "results"
SKILLS_3D = ("pour", "scoop", "push", "stir")
#: The Kitchen2D reference implementation's pour (field facts): particles, tilt rad/s, cap s.
REFERENCE_2D_POUR = {"n_particles": REFERENCE.n_particles, "rotate_speed": REFERENCE.rotate_speed,
                     "max_time": REFERENCE.max_time}
#: The Kitchen3D reference implementation's PyBullet solver iterations (field facts).
REFERENCE_SOLVER_ITERATIONS = 50
#: Controls drawn per context when looking for one that both pre-checks accept.
CONTROLS_PER_DRAW = 16
#: Goals drawn (uniform over the goal dimensions' context box) per input for the goal sweep
#: of a skill with an outcome (:func:`goal_sweep`).
SWEEP_GOALS = 32
#: Bootstrap resamples of the inputs for the goal sweep's interval.
SWEEP_BOOTSTRAP = 2000


def _box2d(**pour_changes: float) -> SkillBackend:
    """The Box2D backend with its pour settings changed (none: as shipped)."""
    backend = Kitchen2DBackend()
    backend.config = replace(backend.config, pour=replace(PourConfig(), **pour_changes))
    return backend


def _sapien_placed_spoon() -> SkillBackend:
    """The SAPIEN backend whose scoop spoon is a placed dynamic body (issue #21's option,
    ``SapienWorldConfig.spoon_tool = "placed"``, rest offset as fitted)."""
    backend = load_backend("sapien")
    backend.config = replace(backend.config, spoon_tool="placed")  # type: ignore[attr-defined]
    return backend


def _box2d_reference_scoop() -> SkillBackend:
    """The Box2D backend with the reference implementation's scoop grains."""
    backend = Kitchen2DBackend()
    backend.config = replace(backend.config, scoop=reference_scoop())
    return backend


#: Setting name -> how to build its backend (built when a row needs it, closed after).
SETTINGS: dict[str, Callable[[], SkillBackend]] = {
    "box2d": lambda: load_backend("box2d"),
    "box2d-reference-pour": lambda: _box2d(**REFERENCE_2D_POUR),
    "box2d-500-particles": lambda: _box2d(n_particles=REFERENCE.n_particles),
    "box2d-tilt-0.1": lambda: _box2d(rotate_speed=REFERENCE.rotate_speed,
                                     max_time=REFERENCE.max_time),
    "box2d-reference-scoop": _box2d_reference_scoop,
    "pybullet": lambda: load_backend("pybullet"),
    "pybullet-solver-50": lambda: load_backend(
        "pybullet", solver_iterations=REFERENCE_SOLVER_ITERATIONS
    ),
    # An intermediate count, screened on a row's disagreeing inputs (bench/label_stability.py).
    "pybullet-solver-20": lambda: load_backend("pybullet", solver_iterations=20),
    # 5 iterations for every skill: the scoop's shipped setting before it took 50.
    "pybullet-solver-5": lambda: load_backend("pybullet", solver_iterations=5),
    "sapien": lambda: load_backend("sapien"),
    "sapien-placed-spoon": _sapien_placed_spoon,
    "pybullet-panda": lambda: load_backend("pybullet", robot="panda"),
}

#: The versioned settings' engines: a setting's physics version is its engine's for the
#: skill (see :func:`setting_version`). The Box2D settings are unversioned: their committed
#: caches are keyed without one. The Panda's key also names the skill's robot setup version
#: (:data:`ROBOT_SETUP_VERSIONS`, e.g. ``1r3``; setup 1's keys were ``pybullet-panda@v1``).
SETTING_ENGINES: dict[str, str] = {
    "pybullet": "pybullet",
    "pybullet-solver-50": "pybullet",
    "pybullet-solver-20": "pybullet",
    "pybullet-solver-5": "pybullet",
    "pybullet-panda": "pybullet",
    "sapien": "sapien",
    "sapien-placed-spoon": "sapien",
}


def setting_version(setting: str, skill: str) -> str | None:
    """The physics version of ``setting``'s ``skill`` trials (part of their cache keys):
    PyBullet's per-skill version (``"1"``; the push ``"1.1"``), SAPIEN's per-skill version
    (``"3"``), or ``None`` for an unversioned (Box2D) setting."""
    engine = SETTING_ENGINES.get(setting)
    if engine == "pybullet":
        return pybullet_physics_version(skill)
    if engine == "sapien":
        return sapien_physics_version(skill)
    return None


#: The fast side of a ``3d-<skill>-solver`` row: the shipped PyBullet setting, except for a
#: skill that ships the reference's 50 iterations (the scoop, issues #20/#21), whose row keeps
#: comparing 5 with 50 (its keys then name ``pybullet-solver-5``; the committed row's
#: 5-iteration trials were keyed ``pybullet@v1``, before the scoop's physics revision).
SOLVER_ROW_FAST: dict[str, str] = {"scoop": "pybullet-solver-5"}


@dataclass(frozen=True)
class Row:
    """One comparison: ``skill`` under the ``fast`` and the ``reference`` setting."""

    name: str
    skill: str
    fast: str
    reference: str


ROWS: tuple[Row, ...] = (
    Row("2d-pour-reference", "pour", "box2d", "box2d-reference-pour"),
    Row("2d-pour-particles", "pour", "box2d", "box2d-500-particles"),
    Row("2d-pour-tilt", "pour", "box2d", "box2d-tilt-0.1"),
    Row("2d-scoop-reference", "scoop", "box2d", "box2d-reference-scoop"),
    *(Row(f"3d-{skill}-engine", skill, "pybullet", "sapien") for skill in SKILLS_3D),
    *(Row(f"3d-{skill}-solver", skill, SOLVER_ROW_FAST.get(skill, "pybullet"),
          "pybullet-solver-50") for skill in SKILLS_3D),
    *(Row(f"3d-{skill}-robot", skill, "pybullet", "pybullet-panda") for skill in SKILLS_3D),
    Row("3d-scoop-placed-spoon", "scoop", "pybullet", "sapien-placed-spoon"),
)


def is_success(result: dict) -> bool:
    """The label of a trial record: valid and ``score > 0``."""
    return bool(result["valid"]) and float(result["score"]) > 0.0


def draw_inputs(fast: SkillBackend, reference: SkillBackend, skill: str, n: int, seed: int
                ) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n`` (context ``(d_context,)``, control ``(d_control,)``) pairs whose control both
    settings' pre-checks accept, drawn with a generator seeded by ``seed``."""
    rng = np.random.default_rng(seed)
    spec = fast.skills()[skill]
    inputs: list[tuple[np.ndarray, np.ndarray]] = []
    while len(inputs) < n:
        context = fast.sample_context(skill, rng)
        # One at a time: a 3D pre-check costs milliseconds per control.
        for control in spec.control.sample_uniform(rng, CONTROLS_PER_DRAW):
            if (fast.is_valid(skill, context, control[None])[0]
                    and reference.is_valid(skill, context, control[None])[0]):
                inputs.append((context, control))
                break
    return inputs


def _same_precheck(a: str, b: str) -> bool:
    """Whether settings ``a`` and ``b`` accept the same controls: the same setting, or two
    SAPIEN settings (every SAPIEN setting pre-checks with the shared Kitchen3D kinematics)."""
    return a == b or SETTING_ENGINES.get(a) == SETTING_ENGINES.get(b) == "sapien"


def stored_inputs(path: Path | None, fast: SkillBackend, reference: SkillBackend, skill: str,
                  n: int, seed: int, fast_name: str, reference_name: str
                  ) -> list[tuple[np.ndarray, np.ndarray]]:
    """:func:`draw_inputs`, kept in the JSON file ``path`` (``None``: always drawn).

    Drawing costs a pre-check per candidate control (~40 ms on PyBullet; ~0.3 s per input),
    so several shards of a long row would each redraw for a minute or more. The file holds
    the skill, seed, both settings and the inputs ``[context..., control...]``; the first
    ``n`` of a longer list are the same as ``n`` drawn (the draws are sequential), so a file
    with at least ``n`` inputs drawn with the same pre-checks (:func:`_same_precheck`) is
    reused, any other is redrawn and rewritten."""
    if path is not None and path.exists():
        stored = json.loads(path.read_text())
        if (stored["skill"] == skill and stored["seed"] == seed
                and all(_same_precheck(a, b) for a, b in
                        zip(stored["settings"], (fast_name, reference_name), strict=True))
                and len(stored["inputs"]) >= n):
            spec = fast.skills()[skill]
            rows = np.asarray(stored["inputs"][:n], dtype=float)
            return [(row[:spec.context.dim], row[spec.context.dim:]) for row in rows]
    inputs = draw_inputs(fast, reference, skill, n, seed)
    if path is not None:
        partial = path.with_suffix(".tmp")
        partial.write_text(json.dumps({
            "skill": skill, "seed": seed, "settings": [fast_name, reference_name],
            "inputs": [[*context.tolist(), *control.tolist()] for context, control in inputs]}))
        partial.replace(path)
    return inputs


def trial_key(setting: str, skill: str, context: np.ndarray, control: np.ndarray,
              seed: int) -> str:
    """The cache key of one trial (inputs rounded to 12 digits, so JSON round trips match);
    a versioned setting's name carries ``@v<physics version>`` (:func:`setting_version`)."""
    values = ",".join(f"{v:.12g}" for v in (*context, *control))
    version = setting_version(setting, skill)
    name = setting if version is None else f"{setting}@v{version}"
    robot_version = ROBOT_SETUP_VERSIONS.get(skill, 1)
    if setting == "pybullet-panda" and robot_version > 1:
        name += f"r{robot_version}"
    return f"{name}|{skill}|{seed}|{values}"


def load_cache(path: Path) -> dict[str, dict]:
    """Trial records already in the JSONL cache, by key (a torn last line is skipped)."""
    records: dict[str, dict] = {}
    if not path.exists():
        return records
    with path.open() as lines:
        for line in lines:
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                continue
            records[record["key"]] = record
    return records


def append_record(path: Path, record: dict) -> None:
    """Append one record as one line, in one write, flushed to disk (after a newline if a
    stopped run left a torn last line)."""
    with path.open("ab+") as out:
        torn = out.seek(0, os.SEEK_END) > 0 and out.seek(-1, os.SEEK_END) >= 0 and (
            out.read(1) != b"\n")
        out.write((("\n" if torn else "") + json.dumps(record) + "\n").encode())
        out.flush()
        os.fsync(out.fileno())


def run_trial(backend: SkillBackend, setting: str, skill: str, context: np.ndarray,
              control: np.ndarray, seed: int) -> dict:
    """One trial as a record: score, valid, CPU seconds, or the error that stopped it."""
    start = time.process_time()
    try:
        result = backend.run_trial(skill, context, control, seed)
    except ValueError as error:  # e.g. the reference's 500 particles do not fit a small cup
        return {"score": None, "valid": False, "error": str(error),
                "cpu_s": time.process_time() - start}
    record = {"score": float(result.score), "valid": bool(result.valid), "error": None,
              "cpu_s": time.process_time() - start, "reason": result.info.get("reason")}
    if result.outcome is not None:
        # A skill with an outcome (the 3D push's end pose): disagreements can then be
        # traced to how far apart the two settings' outcomes are, and the label at any
        # other goal recomputed without a rerun.
        record["outcome"] = [float(v) for v in result.outcome]
    return record


@contextmanager
def backends(names: tuple[str, ...]) -> Iterator[dict[str, SkillBackend]]:
    """The named settings' backends, closed on exit."""
    with ExitStack() as stack:
        built = {}
        for name in names:
            backend = SETTINGS[name]()
            stack.callback(backend.close)
            built[name] = backend
        yield built


def run_row(row: Row, n: int, seed: int, cache_path: Path, cache: dict[str, dict],
            progress: bool, shard: tuple[int, int] = (0, 1),
            only: frozenset[str] | None = None, first: int = 0,
            inputs_path: Path | None = None) -> dict:
    """Run (or reuse from the cache) the row's trials and summarise the agreement.

    ``first``: only inputs ``i >= first`` of the ``n`` drawn are run and summarised (the
    inputs and trial seeds are the same as in a run from 0, so ``--trials 400
    --first-input 200`` validates on the 200 inputs after a 200-input row's). ``inputs_path``:
    keep the drawn inputs there (:func:`stored_inputs`).

    ``shard = (k, m)`` runs only inputs ``i`` with ``i % m == k`` (several processes can
    share a long row through one cache); the others count only once cached. ``only``: run
    the trials of these settings only (``None``: all); the others count only once cached."""
    with backends((row.fast, row.reference)) as built:
        fast, reference = built[row.fast], built[row.reference]
        inputs = stored_inputs(inputs_path, fast, reference, row.skill, n, seed, row.fast,
                               row.reference)
        pairs = []
        for index, (context, control) in enumerate(inputs):
            if index < first:
                continue
            trial_seed = seed * 100_000 + index
            pair = []
            for setting, backend in ((row.fast, fast), (row.reference, reference)):
                key = trial_key(setting, row.skill, context, control, trial_seed)
                if key not in cache and (index % shard[1] != shard[0]
                                         or (only is not None and setting not in only)):
                    cache.update(load_cache(cache_path))  # another shard may have run it
                    if key not in cache:
                        continue  # the other setting may still run
                if key not in cache:
                    # Another process on the same cache (an overlapping shard) may have run
                    # it since: reading the cache costs milliseconds, a trial seconds.
                    cache.update(load_cache(cache_path))
                if key not in cache:
                    record = {"key": key, "setting": setting, "skill": row.skill,
                              "seed": trial_seed, "context": context.tolist(),
                              "control": control.tolist(),
                              **run_trial(backend, setting, row.skill, context, control,
                                          trial_seed)}
                    append_record(cache_path, record)
                    cache[key] = record
                pair.append(cache[key])
            if len(pair) == 2:
                pairs.append(pair)
            if progress:
                print(f"\r{row.name}: {index + 1}/{n}", end="", file=sys.stderr, flush=True)
        if progress:
            print(file=sys.stderr)
        spec = fast.skills()[row.skill]
    return summarise(row, pairs, spec)


def summarise(row: Row, pairs: list[list[dict]], spec: SkillSpec | None = None) -> dict:
    """Success rates, agreement with its Wilson interval, disagreements, CPU per trial.

    ``either_success`` / ``both_success``: inputs on which at least one / both settings
    succeed (when successes are rare, agreement is high whatever the settings do; the
    share of the first that is the second says how often a success is reproduced). With
    ``spec`` of a skill with an outcome whose records carry outcomes, also
    :func:`goal_sweep` (``goal_sweep``) and :func:`outcome_differences`."""
    kept = [(f, r) for f, r in pairs if f["error"] is None and r["error"] is None]
    fast_labels = np.array([is_success(f) for f, _ in kept], dtype=bool)
    ref_labels = np.array([is_success(r) for _, r in kept], dtype=bool)
    n = len(kept)
    agree = int((fast_labels == ref_labels).sum())
    low, high = wilson_interval(agree, n)
    return {
        "row": row.name, "skill": row.skill, "fast": row.fast, "reference": row.reference,
        "trials": n, "errors": len(pairs) - n,
        "fast_success": float(fast_labels.mean()) if n else None,
        "reference_success": float(ref_labels.mean()) if n else None,
        "agreement": agree / n if n else None, "wilson95": [low, high],
        "fast_only": int((fast_labels & ~ref_labels).sum()),
        "reference_only": int((~fast_labels & ref_labels).sum()),
        "fast_cpu_s": float(np.mean([f["cpu_s"] for f, _ in pairs])) if pairs else None,
        "reference_cpu_s": float(np.mean([r["cpu_s"] for _, r in pairs])) if pairs else None,
        "cpu_ratio": (float(np.mean([r["cpu_s"] for _, r in pairs])
                            / np.mean([f["cpu_s"] for f, _ in pairs])) if pairs else None),
        "reference_reasons": _count_reasons(r for _, r in kept),
        "either_success": int((fast_labels | ref_labels).sum()),
        "both_success": int((fast_labels & ref_labels).sum()),
        **_agreement_where_run(kept),
        **_outcome_summaries(spec, kept),
    }


def _outcome_summaries(spec: SkillSpec | None, kept: list[tuple[dict, dict]]) -> dict:
    """The goal sweep and outcome differences of a skill with an outcome (else nothing)."""
    if spec is None or spec.outcome is None:
        return {}
    if not any("outcome" in f or "outcome" in r for f, r in kept):
        return {}  # records cached before outcomes were kept
    return {"goal_sweep": goal_sweep(spec, kept),
            "outcome_differences": outcome_differences(spec, kept)}


def _labels_over_goals(spec: SkillSpec, record: dict, goals: np.ndarray) -> np.ndarray:
    """The record's label (bool ``(n_goals,)``) at each of ``goals`` ``(n_goals, d_goal)``:
    valid and the outcome's declared score > 0 at that goal. A record without an outcome
    (not simulated, e.g. a robot that could not reach) keeps its own label at every goal."""
    if "outcome" not in record:
        return np.full(len(goals), is_success(record))
    assert spec.outcome is not None
    contexts = np.repeat(np.asarray(record["context"], dtype=float)[None], len(goals), axis=0)
    contexts[:, list(spec.outcome.goals)] = goals
    controls = np.repeat(np.asarray(record["control"], dtype=float)[None], len(goals), axis=0)
    outcomes = np.repeat(np.asarray(record["outcome"], dtype=float)[None], len(goals), axis=0)
    return bool(record["valid"]) & (spec.outcome.scores(contexts, controls, outcomes) > 0.0)


def goal_sweep(spec: SkillSpec, kept: list[tuple[dict, dict]], n_goals: int = SWEEP_GOALS,
               seed: int = 0) -> dict:
    """Label agreement of the two settings at ``n_goals`` goals per input instead of the drawn
    one (a skill with an outcome: the physics does not see the goal, so one trial's outcome
    labels it at every goal; the label is recomputed by the declared score).

    The goals are drawn uniformly over the goal dimensions' context box (one set for all
    inputs, ``default_rng(seed)``). The input × goal units share trials, so the interval is
    a bootstrap over inputs (95 %, :data:`SWEEP_BOOTSTRAP` resamples), not a Wilson one.
    Returns the agreement, its interval, each setting's success rate over the units, the
    units where either / both succeed, and the inputs with at least one disagreeing goal."""
    assert spec.outcome is not None
    index = list(spec.outcome.goals)
    lows = np.asarray(spec.context.lows, dtype=float)[index]
    highs = np.asarray(spec.context.highs, dtype=float)[index]
    goals = np.random.default_rng(seed).uniform(lows, highs, size=(n_goals, len(index)))
    fast = np.array([_labels_over_goals(spec, f, goals) for f, _ in kept]).reshape(-1, n_goals)
    ref = np.array([_labels_over_goals(spec, r, goals) for _, r in kept]).reshape(-1, n_goals)
    per_input = (fast == ref).mean(axis=1)  # (n_inputs,)
    resampled = np.random.default_rng(seed).integers(0, len(kept),
                                                     size=(SWEEP_BOOTSTRAP, len(kept)))
    means = per_input[resampled].mean(axis=1) if len(kept) else np.zeros(1)
    return {"goals_per_input": n_goals, "units": int(fast.size),
            "agreement": float(per_input.mean()) if len(kept) else None,
            "bootstrap95": [float(np.quantile(means, 0.025)), float(np.quantile(means, 0.975))],
            "fast_success": float(fast.mean()) if fast.size else None,
            "reference_success": float(ref.mean()) if ref.size else None,
            "either_success": int((fast | ref).sum()), "both_success": int((fast & ref).sum()),
            "inputs_with_a_disagreement": int((per_input < 1.0).sum())}


def outcome_differences(spec: SkillSpec, kept: list[tuple[dict, dict]]) -> dict:
    """Per outcome value (its name and unit from the spec), the median, 90th percentile and
    maximum of ``|fast − reference|`` over the inputs both settings simulated."""
    assert spec.outcome is not None
    both = [(f["outcome"], r["outcome"]) for f, r in kept if "outcome" in f and "outcome" in r]
    if not both:
        return {"inputs": 0}
    diff = np.abs(np.array([f for f, _ in both], dtype=float)
                  - np.array([r for _, r in both], dtype=float))  # (n, d_outcome)
    space = spec.outcome.space
    units = space.units or ("",) * space.dim  # units are optional in a ParamSpace
    return {"inputs": len(both), **{
        f"{name} ({unit})" if unit else name: {
            "median": float(np.median(diff[:, i])), "p90": float(np.quantile(diff[:, i], 0.9)),
            "max": float(diff[:, i].max())}
        for i, (name, unit) in enumerate(zip(space.names, units, strict=True))}}


def _agreement_where_run(kept: list[tuple[dict, dict]]) -> dict:
    """Agreement on the inputs whose reference trial gave no failure reason (for the robot
    row: those the Panda grasped, reached and carried out), with its Wilson interval, and
    the CPU seconds per trial of both settings there."""
    ran = [(f, r) for f, r in kept if "reason" in r and not r["reason"]]
    if not ran:
        return {}
    agree = sum(is_success(f) == is_success(r) for f, r in ran)
    return {"ran_trials": len(ran), "ran_agreement": agree / len(ran),
            "ran_wilson95": list(wilson_interval(agree, len(ran))),
            "ran_fast_cpu_s": float(np.mean([f["cpu_s"] for f, _ in ran])),
            "ran_reference_cpu_s": float(np.mean([r["cpu_s"] for _, r in ran]))}


def _count_reasons(records: Iterable[dict]) -> dict[str, int]:
    """How many trials gave each ``info["reason"]`` (failures that say why; older cached
    records without the field are not counted)."""
    counts: dict[str, int] = {}
    for record in records:
        reason = record.get("reason")
        if reason:
            counts[reason] = counts.get(reason, 0) + 1
    return dict(sorted(counts.items()))


def print_table(summaries: list[dict], target: float) -> None:
    """The rows as a table: ``>=T`` compares the point estimate with ``target``; ``low>=T``
    the Wilson interval's lower end (the rule the engine choice uses,
    ``bench.paper.pools.engine_agrees``); ``both/eith``: inputs where both / either setting
    succeed (with rare successes agreement is high whatever the settings do)."""
    header = (f"{'row':<20} {'n':>4} {'err':>3} {'fast ok':>7} {'ref ok':>6} {'agree':>6} "
              f"{'wilson95':>13} {'f-only':>6} {'r-only':>6} {'both/eith':>9} {'cpu f':>6} "
              f"{'cpu r':>6} >={target:.2f} low>={target:.2f}")
    print(header)
    print("-" * len(header))
    for s in summaries:
        if not s["trials"]:
            print(f"{s['row']:<20} {0:>4} {s['errors']:>3}  (no comparable trials)")
            continue
        low, high = s["wilson95"]
        both_either = f"{s['both_success']}/{s['either_success']}"
        print(f"{s['row']:<20} {s['trials']:>4} {s['errors']:>3} {s['fast_success']:>7.2f} "
              f"{s['reference_success']:>6.2f} {s['agreement']:>6.3f} "
              f"{low:>6.3f}-{high:<6.3f} {s['fast_only']:>6} {s['reference_only']:>6} "
              f"{both_either:>9} {s['fast_cpu_s']:>6.2f} {s['reference_cpu_s']:>6.2f} "
              f"{'yes' if s['agreement'] >= target else 'no':>7} "
              f"{'yes' if low >= target else 'no':>8}")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    names = [row.name for row in ROWS]
    parser.add_argument("--rows", nargs="+", choices=names, default=names, metavar="ROW",
                        help=f"comparisons to run (default all): {', '.join(names)}")
    parser.add_argument("--trials", type=int, default=200, help="inputs per row")
    parser.add_argument("--seed", type=int, default=0, help="seeds the inputs and trials")
    parser.add_argument("--target", type=float, default=0.95, help="agreement to reach")
    parser.add_argument("--cache", type=Path, default=RESULTS_DIR / "fidelity_trials.jsonl")
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "fidelity.json")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")
    parser.add_argument("--first-input", type=int, default=0, metavar="I",
                        help="run and summarise only inputs I..trials-1 (same draws and "
                             "trial seeds as from 0: fresh inputs after an earlier row's)")
    parser.add_argument("--inputs", type=Path, default=None, metavar="JSON",
                        help="keep the drawn inputs in this file (one row only) and reuse "
                             "them: shards of a long row then draw once")
    parser.add_argument("--shard", default="0/1", metavar="K/M",
                        help="run only inputs i with i %% M == K (others: from the cache)")
    parser.add_argument("--settings", nargs="*", choices=sorted(SETTINGS), metavar="SETTING",
                        help="run only these settings' trials (others: from the cache); "
                             "none named: only summarise the cached pairs")
    args = parser.parse_args(argv)
    if args.trials < 1:
        parser.error("--trials must be at least 1")
    if not 0 <= args.first_input < args.trials:
        parser.error("--first-input must be in [0, --trials)")
    if args.inputs is not None and len(args.rows) != 1:
        parser.error("--inputs keeps one row's inputs: name exactly one --rows")
    if not 0.0 < args.target <= 1.0:
        parser.error("--target must be in (0, 1]")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    args.cache.parent.mkdir(parents=True, exist_ok=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    cache = load_cache(args.cache)
    by_name = {row.name: row for row in ROWS}
    chosen = [by_name[name] for name in dict.fromkeys(args.rows)]  # in the order given
    k, m = (int(v) for v in args.shard.split("/"))
    only = frozenset(args.settings) if args.settings is not None else None
    summaries = [run_row(row, args.trials, args.seed, args.cache, cache, not args.quiet, (k, m),
                         only, args.first_input, args.inputs)
                 for row in chosen]
    print_table(summaries, args.target)
    report = {"trials": args.trials, "first_input": args.first_input, "seed": args.seed,
              "target": args.target,
              "machine": platform.platform(), "rows": summaries}
    partial = args.out.with_suffix(".json.tmp")
    partial.write_text(json.dumps(report, indent=1))
    partial.replace(args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
