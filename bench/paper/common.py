"""What every paper experiment shares: the run context, JSON/PNG output and live scoring.

Nothing here holds state between experiments: each ``run(ctx)`` gets a :class:`Context`.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import platform
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.protocol import SkillBackend
from ltamp_cli.learning.active import GP_STRATEGIES
from ltamp_cli.learning.gp import FIT_OBJECTIVE

REPO = Path(__file__).resolve().parents[2]
MODES = ("smoke", "quick", "standard", "full")


@dataclass(frozen=True)
class Context:
    """One experiment run: ``mode`` (smoke/quick/standard/full), output folder, progress bars.

    ``standard`` (≤ 2 h on 2 cores) sizes the Kitchen2D experiments for the report's paired
    tests; an experiment without a ``standard`` row (the Kitchen3D ones, which need trial
    pools of hours) runs its ``quick`` row.
    """

    mode: str
    out: Path
    progress: bool
    workers: int = 2

    def sizes(self, table: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
        """The row of a module's ``SIZES`` table for this mode."""
        if self.mode == "standard" and "standard" not in table:
            return dict(table["quick"])
        return dict(table[self.mode])

    @property
    def cache(self) -> Path:
        """Regenerable data (trial pools, trained models) lives here, under ``out``."""
        path = self.out / "cache"
        path.mkdir(parents=True, exist_ok=True)
        return path


class JobLog:
    """The finished jobs of one experiment, so that a rerun continues where a run stopped.

    A job (one learner × seed × skill, say) is recorded as one JSON line ``{"key", "sizes",
    "rows"}`` appended to ``<out>/runs/<experiment>-<mode>.jsonl`` once it has finished
    (one ``write`` of a whole line, flushed and fsynced: an interrupted run loses at most the
    job it was running, and a torn last line is ignored). Lines recorded under other sizes
    (``sizes`` is the experiment's row of its ``SIZES`` table) are ignored, so changing a
    mode's sizes reruns its jobs. The logs are results, committed with the report (unlike
    ``cache/``), so a long run can be finished in several sessions.
    """

    def __init__(self, ctx: Context, experiment: str, sizes: Mapping[str, Any]) -> None:
        folder = ctx.out / "runs"
        folder.mkdir(parents=True, exist_ok=True)
        self.path = folder / f"{experiment}-{ctx.mode}.jsonl"
        self.sizes = sizes_hash(sizes)
        self._done: dict[str, list[dict[str, Any]]] = {
            str(entry["key"]): list(entry["rows"]) for entry in read_entries(self.path,
                                                                             self.sizes)}

    def get(self, key: str) -> list[dict[str, Any]] | None:
        """The rows of job ``key`` if it finished in an earlier (or this) run."""
        return self._done.get(key)

    def put(self, key: str, rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """Record finished job ``key`` with its result ``rows``; returns them as a rerun will
        read them back (JSON values: lists for tuples, floats for numpy scalars)."""
        line = json.dumps({"key": key, "sizes": self.sizes, "rows": rows},
                          default=_jsonable) + "\n"
        append_line(self.path, line)
        self._done[key] = json.loads(line)["rows"]
        return self._done[key]

    def run(self, key: str, job: Callable[[], list[dict[str, Any]]]) -> list[dict[str, Any]]:
        """``job()``'s rows, computed now or read back from an earlier run."""
        rows = self.get(key)
        return self.put(key, job()) if rows is None else rows


def append_line(path: Path, line: str) -> None:
    """Append one JSON ``line`` (ending in a newline) to ``path``: one unbuffered write under
    an exclusive lock, fsynced. The parts of a split experiment (one per skill) may run in
    parallel processes and share a log: the lock keeps the torn-line check and the append
    together (a buffered write could be split and interleaved); a line torn by an
    interruption is ended first, so readers skip it and nothing else."""
    with path.open("a+b", buffering=0) as handle:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX)
        size = os.fstat(handle.fileno()).st_size
        if size > 0 and os.pread(handle.fileno(), 1, size - 1) != b"\n":
            line = "\n" + line
        data = line.encode("utf-8")
        while data:
            data = data[os.write(handle.fileno(), data):]
        os.fsync(handle.fileno())


def read_entries(path: Path, sizes: str) -> list[dict[str, Any]]:
    """The JSON-object lines of ``path`` recorded under the sizes hash ``sizes``, in file
    order (torn lines and lines of other sizes skipped; no file: none)."""
    if not path.is_file():
        return []
    entries = []
    for line in path.read_text().splitlines():
        try:
            entry = json.loads(line)
        except json.JSONDecodeError:
            continue  # a line torn by an interruption
        if isinstance(entry, dict) and entry.get("sizes") == sizes:
            entries.append(entry)
    return entries


class CheckpointLog:
    """The finished checkpoints of unfinished jobs, so that a rerun continues *inside* a job.

    A pooled experiment's job (learner × seed) evaluates F1 and the simulated θ* success rate
    at up to 40 checkpoints; at full size one job is ~10 CPU minutes, hours on a loaded
    machine, and an interruption used to lose all of it. Each evaluated checkpoint is one
    line ``{"key", "sizes", "n_trials", "f1", "success_rate", "successes", "scorer"}``
    appended to ``<out>/runs/<experiment>-<mode>-checkpoints.jsonl`` (``scorer``: how many
    live trials the job's true-score function had run after it, so a rerun's trial seeds
    continue where the logged ones stopped). A rerun of the job replays its learning (cheap:
    the model fits) and reads these evaluations back instead of recomputing them; the job's
    final rows are byte-identical to an uninterrupted run's (``tests/bench``). Same sizes
    hash as the experiment's :class:`JobLog`.
    """

    def __init__(self, ctx: Context, experiment: str, sizes: Mapping[str, Any]) -> None:
        folder = ctx.out / "runs"
        folder.mkdir(parents=True, exist_ok=True)
        self.path = folder / f"{experiment}-{ctx.mode}-checkpoints.jsonl"
        self.sizes = sizes_hash(sizes)
        self._done: dict[str, dict[int, dict[str, Any]]] = {}
        for entry in read_entries(self.path, self.sizes):
            self._done.setdefault(str(entry["key"]), {})[int(entry["n_trials"])] = entry

    def get(self, key: str) -> dict[int, dict[str, Any]]:
        """Job ``key``'s logged checkpoints: ``{n_trials: entry}`` (a copy)."""
        return dict(self._done.get(key, {}))

    def put(self, key: str, entry: dict[str, Any]) -> dict[str, Any]:
        """Record one evaluated checkpoint ``entry`` (``n_trials``, metrics, ``scorer``) of
        job ``key``; returns it as a rerun will read it back."""
        line = json.dumps({"key": key, "sizes": self.sizes, **entry}, default=_jsonable) + "\n"
        append_line(self.path, line)
        stored = json.loads(line)
        self._done.setdefault(key, {})[int(stored["n_trials"])] = stored
        return stored


def fit_key(key: str, strategy: str) -> str:
    """Job ``key`` of a learner using ``strategy``, naming the GP fit objective when the
    learner fits GPs (:data:`~ltamp_cli.learning.gp.FIT_OBJECTIVE`): a job logged under an
    earlier default fit is rerun, not mixed with this fit's jobs. Learners without a GP
    keep their keys (their logged jobs stay valid)."""
    return f"{key}@{FIT_OBJECTIVE}" if strategy in GP_STRATEGIES else key


def sizes_hash(sizes: Mapping[str, Any]) -> str:
    """The 16-hex-digit hash under which a log's lines are recorded (``sizes``: the
    experiment's row of its ``SIZES`` table, or what its jobs depend on)."""
    return hashlib.sha256(json.dumps(sizes, sort_keys=True, default=str)
                          .encode()).hexdigest()[:16]


def machine() -> dict[str, Any]:
    """Where the numbers were measured (the report states it)."""
    return {
        "python": platform.python_version(),
        "platform": platform.platform(terse=True),
        "cpus": os.cpu_count(),
        "load_1min": round(os.getloadavg()[0], 2),
        "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
    }


def write_json(ctx: Context, name: str, payload: dict[str, Any], started: float) -> Path:
    """Write ``<out>/<name>.json`` with the mode, machine and elapsed wall/CPU seconds."""
    payload = {
        "experiment": name,
        "mode": ctx.mode,
        "machine": machine(),
        "wall_s": round(time.perf_counter() - started, 1),
        **payload,
    }
    path = ctx.out / f"{name}.json"
    path.write_text(json.dumps(payload, indent=2, default=_jsonable) + "\n")
    return path


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON-serialisable: {type(value).__name__}")


def progress_enabled() -> bool:
    return sys.stderr.isatty()


class LiveScore:
    """True score by simulation: ``(contexts (k, dα), controls (k, dθ)) -> scores (k,)``.

    Each call runs ``k`` real trials on ``backend``; trial ``i`` of the scorer's life has
    seed ``SeedSequence([seed, i])`` (``position`` counts them), so a run is reproducible
    and a resumed one can :meth:`seek` past trials whose outcomes it already logged.
    ``key`` (e.g. ``fraction_in_bowl``) is collected into ``infos`` for metrics other than
    the score.
    """

    def __init__(self, backend: SkillBackend, skill: str, seed: int,
                 key: str | None = None) -> None:
        self.backend = backend
        self.skill = skill
        self.seed = seed
        self.key = key
        self.position = 0
        self.infos: list[dict[str, Any]] = []

    def seek(self, position: int) -> None:
        """Continue as if ``position`` trials had run (a resumed job's logged ones)."""
        if position < 0:
            raise ValueError(f"a scorer position is >= 0, got {position}")
        self.position = position

    def __call__(self, contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
        contexts = np.atleast_2d(np.asarray(contexts, dtype=float))
        controls = np.atleast_2d(np.asarray(controls, dtype=float))
        if len(contexts) == 1 and len(controls) > 1:
            contexts = np.repeat(contexts, len(controls), axis=0)
        out = np.empty(len(controls))
        for i, (context, control) in enumerate(zip(contexts, controls, strict=True)):
            trial_seed = int(np.random.SeedSequence([self.seed, self.position])
                             .generate_state(1)[0])
            self.position += 1
            result = self.backend.run_trial(self.skill, context, control,
                                            trial_seed & 0x7FFFFFFF)
            out[i] = result.score if np.isfinite(result.score) else -1.0
            self.infos.append({"score": out[i], "valid": bool(result.valid),
                               **({self.key: result.info.get(self.key)} if self.key else {})})
        return out


def live_score(backend: SkillBackend, skill: str, seed: int, key: str | None = None
               ) -> LiveScore:
    """The :class:`LiveScore` of ``skill`` on ``backend`` with trial seeds from ``seed``."""
    return LiveScore(backend, skill, seed, key)


def unavailable(what: str) -> dict[str, Any]:
    """A row for something this checkout does not have (reported, never a crash)."""
    return {"available": False, "note": f"{what}: not available in this checkout"}


def mean_std(values: list[float] | np.ndarray) -> dict[str, float | None]:
    array = np.asarray([v for v in values if v is not None], dtype=float)
    if array.size == 0:
        return {"mean": None, "std": None, "n": 0}
    return {"mean": float(array.mean()), "std": float(array.std()), "n": int(array.size)}


def plot_panels(
    panels: list[dict[str, Any]], path: Path, title: str = "", ylabel: str = ""
) -> Path:
    """One PNG with a panel per entry: ``{"title", "series": {label: (x, mean, err)}}``.

    ``err`` is drawn as a shaded band (the paper shades a fraction of the standard error).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 3.6), squeeze=False)
    for axis, panel in zip(axes[0], panels, strict=True):
        for label, (x, mean, err) in panel["series"].items():
            x, mean, err = (np.asarray(v, dtype=float) for v in (x, mean, err))
            axis.plot(x, mean, marker="o", markersize=3, label=label)
            axis.fill_between(x, mean - err, mean + err, alpha=0.2)
        axis.set_title(panel["title"], fontsize=10)
        axis.set_xlabel(panel.get("xlabel", "number of trials"))
        axis.set_ylabel(panel.get("ylabel", ylabel))
        if panel.get("unit_range", True):
            axis.set_ylim(-0.02, 1.02)
        axis.grid(alpha=0.3)
        if panel["series"]:
            axis.legend(fontsize=8)
        else:
            axis.text(0.5, 0.5, panel.get("empty", "not available"), ha="center",
                      transform=axis.transAxes)
    if title:
        figure.suptitle(title, fontsize=11)
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    plt.close(figure)
    return path


def curve_series(
    summary: list[dict[str, Any]], metric: str, learners: list[str], labels: Mapping[str, str]
) -> dict[str, tuple[list[float], list[float], list[float]]]:
    """``summarize`` rows -> ``{label: (n_trials, mean, stderr)}`` for ``plot_panels``."""
    series = {}
    for learner in learners:
        points = [e for e in summary if e["learner"] == learner and e[f"{metric}_mean"] is not None]
        if points:
            series[labels.get(learner, learner)] = (
                [e["n_trials"] for e in points],
                [e[f"{metric}_mean"] for e in points],
                [e[f"{metric}_stderr"] for e in points],
            )
    return series


def first_valid_lazy(
    is_valid: Callable[[np.ndarray, np.ndarray], np.ndarray], chunk: int = 8, need: int = 3
) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """A validity test for callers that only use the *first few* valid controls of a batch
    sorted by preference.

    ``SkillModel.most_confident_control`` takes the first valid candidate of a sorted block of
    256, the GP's takes the first ``n_restarts = 3`` valid ones (blocks of 64) as L-BFGS-B
    starts. On PyBullet the check costs ~40 ms per control, so a full block is 2.5–10 s. This
    wrapper checks ``chunk`` controls at a time and stops once ``need`` valid ones are found,
    reporting the unchecked rest as invalid: the first ``need`` ``True`` entries are the same
    as with the full test, so the chosen control is unchanged (for ``need`` ≥ the number the
    caller uses).
    """

    def lazy(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
        controls = np.atleast_2d(np.asarray(controls, dtype=float))
        result = np.zeros(len(controls), dtype=bool)
        for start in range(0, len(controls), chunk):
            ok = np.asarray(is_valid(context, controls[start : start + chunk]), dtype=bool)
            result[start : start + len(ok)] = ok
            if result.sum() >= need:
                break
        return result

    return lazy


def wall_limit(cpu_seconds: float, cap: float = 8.0) -> float:
    """A wall-clock limit that gives a process about ``cpu_seconds`` of CPU on this machine now.

    Planner limits are wall-clock. With a 1-minute load above the core count each runnable
    process gets about ``cores / load`` of a core, so the limit is stretched by
    ``load / cores`` (at most ``cap`` times); results are then judged on CPU time.
    """
    cores = os.cpu_count() or 1
    return cpu_seconds * min(cap, max(1.0, os.getloadavg()[0] / cores))
