"""Backend-agnostic, resumable, parallel trial collection.

Trial ``i`` of a job with base seed ``s`` draws everything from
``np.random.SeedSequence(s, spawn_key=(i,))``: its context (``backend.sample_context``), its
control (uniform in the control box, optionally re-drawn until valid) and the seed passed
to ``run_trial``. So trial ``i`` is the same whether it runs first time, after a resume, or
in any worker. Finished trials are appended to the :class:`TrialDataset` one by one as they
arrive (by the driver process only, each tagged with its index); a resumed job skips the
indices already in the file, so a killed job loses at most the trials that were running and
never duplicates one. Trials run in this process (``workers=1``), in forked worker processes
(``workers>1``) or on Ray actors (``ray_address``, see :mod:`.ray_collect`).

A trial whose physics raises, or whose result is not finite, is recorded as invalid with the
skill's invalid score and the reason in ``info["reason"]``; collection goes on (with a
freshly built backend, since a world left mid-trial is not trusted).
"""

from __future__ import annotations

import ctypes
import json
import multiprocessing as mp
import os
import queue
import signal
import sys
import threading
import time
from collections.abc import Iterator, Mapping
from contextlib import ExitStack
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.protocol import SkillBackend, drawn_context, skill_spec, trial_setup
from ltamp_cli.backends.sanity import run_trial_safely
from ltamp_cli.errors import InputError
from ltamp_cli.seeds import usable_seed
from ltamp_cli.trials.physics import backend_physics, check_physics
from ltamp_cli.trials.record import TrialDataset, TrialRecord, setup_words
from ltamp_cli.trials.robots import check_robot
from ltamp_cli.writer_lock import exclusive_writer

VALID_DRAW_BATCH = 256
VALID_DRAW_ROUNDS = 40
VALID_CHECK_CHUNK = 16


@dataclass(frozen=True)
class TrialInput:
    """What trial ``index`` runs: context ``(d_context,)``, control ``(d_control,)``, seed."""

    index: int
    context: np.ndarray
    control: np.ndarray
    seed: int


@dataclass(frozen=True)
class CollectJob:
    """A collection job: ``n`` trials of ``skill`` on backend ``backend`` (with options).

    ``robot``: ``"none"`` (the backend's tools move free-floating) or a robot that carries
    them (``"panda"`` on ``pybullet``); it is passed to the backend as its ``robot`` option
    and is part of the records' identity (:attr:`tag`), so a file never mixes the two.
    ``setup``: the versioned trial setup its records carry (``"panda-r3"``;
    :func:`~ltamp_cli.backends.protocol.trial_setup`), filled in from the backend by
    :func:`with_setup` (:func:`collect` does): a file never mixes two setups either.
    ``physics``: the physics tag its records carry (``"pybullet@v1.1"``,
    :func:`~ltamp_cli.trials.physics.backend_physics`), filled in by :func:`with_setup` too.
    """

    skill: str
    backend: str
    n: int
    seed: int = 0
    valid_only: bool = False
    backend_options: Mapping[str, Any] | None = None
    robot: str = "none"
    setup: str | None = None
    physics: str | None = None

    @property
    def tag(self) -> str:
        """The ``backend`` field of this job's records: ``pybullet`` or ``pybullet+panda``."""
        return self.backend if self.robot == "none" else f"{self.backend}+{self.robot}"

    def options(self) -> dict[str, Any]:
        """Keyword options of :func:`load_backend` (the robot included when there is one)."""
        options = dict(self.backend_options or {})
        if self.robot != "none":
            options["robot"] = self.robot
        return options


def with_setup(job: CollectJob) -> CollectJob:
    """``job`` with the trial setup and physics of its backend's skill
    (:attr:`CollectJob.setup`, :attr:`CollectJob.physics`); an unknown skill is an
    :class:`InputError` naming the backend's skills."""
    backend = load_backend(job.backend, **job.options())
    try:
        skill_spec(backend, job.skill)  # backends without setups know their skills too
        return replace(job, setup=trial_setup(backend, job.skill),
                       physics=backend_physics(backend, job.skill))
    except KeyError as error:
        raise InputError(str(error).strip("'\"")) from None
    finally:
        backend.close()


def trial_seed(base_seed: int, index: int) -> int:
    """The seed ``run_trial`` gets for trial ``index`` (a 32-bit int)."""
    sequence = np.random.SeedSequence(base_seed, spawn_key=(index,))
    return int(sequence.generate_state(1, dtype=np.uint32)[0])


def trial_input(
    backend: SkillBackend, skill: str, base_seed: int, index: int, valid_only: bool = False
) -> TrialInput:
    """Context, control and seed of trial ``index`` (pure function of its arguments)."""
    spec = skill_spec(backend, skill)
    rng = np.random.default_rng(np.random.SeedSequence(base_seed, spawn_key=(index, 1)))
    context = drawn_context(backend, skill, rng)
    control = spec.control.sample_uniform(rng, 1)[0]
    if valid_only:
        for _ in range(VALID_DRAW_ROUNDS):
            batch = spec.control.sample_uniform(rng, VALID_DRAW_BATCH)
            # The first valid control of the batch, checked a chunk at a time: the same choice
            # as checking the whole batch, without paying for the rest (PyBullet's pre-check
            # costs ~30 ms per control).
            chosen = next((start + int(ok[0])
                           for start in range(0, VALID_DRAW_BATCH, VALID_CHECK_CHUNK)
                           if (ok := np.flatnonzero(backend.is_valid(
                               skill, context, batch[start:start + VALID_CHECK_CHUNK]))).size),
                          None)
            if chosen is not None:
                control = batch[chosen]
                break
    return TrialInput(index, context, control, trial_seed(base_seed, index))


def run_one(backend: SkillBackend, job: CollectJob, index: int) -> TrialRecord:
    """Run trial ``index`` of ``job`` on ``backend`` and make its record.

    Exceptions from the trial's physics are recorded (invalid trial), not raised.
    """
    return _run_guarded(backend, job, index)[0]


def _run_guarded(backend: SkillBackend, job: CollectJob, index: int) -> tuple[TrialRecord, bool]:
    """``(record, crashed)``: ``crashed`` when ``run_trial`` raised (the backend may be dirty)."""
    item = trial_input(backend, job.skill, job.seed, index, job.valid_only)
    start = time.perf_counter()
    result, crashed = run_trial_safely(backend, job.skill, item.context, item.control, item.seed)
    return TrialRecord(
        skill=job.skill,
        context=tuple(float(v) for v in item.context),
        control=tuple(float(v) for v in item.control),
        score=float(result.score),
        valid=bool(result.valid),
        seed=item.seed,
        backend=job.tag,
        wall_time_s=time.perf_counter() - start,
        index=index,
        info=dict(result.info),
        outcome=None if result.outcome is None else tuple(result.outcome),
        setup=trial_setup(backend, job.skill),
        physics=backend_physics(backend, job.skill),
    ), crashed


class TrialRunner:
    """Runs trials of one job on a backend it keeps across trials (one per worker).

    After a trial whose physics raised, the backend is closed and rebuilt before the next
    trial, so a half-finished world cannot change later trials.
    """

    def __init__(self, job: CollectJob) -> None:
        self.job = job
        self._backend: SkillBackend | None = None

    def run(self, index: int) -> TrialRecord:
        if self._backend is None:
            self._backend = load_backend(self.job.backend, **self.job.options())
        record, crashed = _run_guarded(self._backend, self.job, index)
        if crashed:
            self.close()
        return record

    def close(self) -> None:
        if self._backend is not None:
            backend, self._backend = self._backend, None
            backend.close()


def pending_indices(dataset: TrialDataset, job: CollectJob, physics: str | None = None,
                    *, same_physics: bool = True) -> list[int]:
    """Indices of ``job`` not yet in ``dataset``; refuses (one line, ``file:line``) a file
    from a different job: another skill, backend, robot, trial setup (``job.setup``) or
    physics (``physics``, default ``job.physics``; both as :func:`with_setup` fills them).
    ``same_physics=False`` skips the physics check (a caller that knows better)."""
    expected = physics if physics is not None else job.physics
    done: dict[int, int] = {}
    for line, record in dataset.iter_numbered():
        where = f"{dataset.path}:{line}"
        if record.skill != job.skill or record.backend != job.tag:
            raise InputError(
                f"{where}: holds {record.backend}/{record.skill} trials, not "
                f"{job.tag}/{job.skill}; use another --out file")
        if record.setup != job.setup:
            raise InputError(
                f"{where}: holds {job.tag}/{job.skill} trials of {setup_words(record.setup)}, "
                f"not {setup_words(job.setup)} (their labels differ); use another --out file")
        if same_physics:
            check_physics((record,), expected, where, "use another --out file")
        if 0 <= record.index < job.n and record.seed != trial_seed(job.seed, record.index):
            raise InputError(
                f"{dataset.path}: trial {record.index} was collected with a different "
                "--seed; resume with the original seed or use another --out file"
            )
        if record.index >= 0 and record.index in done:
            raise InputError(
                f"{dataset.path}: trial {record.index} (seed {record.seed}) is recorded twice "
                f"(records {done[record.index]} and {line}): two writers shared this file; keep "
                "one copy of each trial before resuming"
            )
        done[record.index] = line
    return [i for i in range(job.n) if i not in done]


PR_SET_PDEATHSIG = 1


def die_with_parent(parent: int) -> None:
    """End this worker process when ``parent`` (the collecting driver) dies.

    On Linux the kernel sends SIGKILL (``prctl(PR_SET_PDEATHSIG)``); elsewhere a daemon
    thread polls the parent id. Either way no worker outlives a killed ``collect``.
    """
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            if libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0:
                if os.getppid() != parent:  # the parent died before prctl took effect
                    os._exit(1)
                return
        except (OSError, AttributeError):
            pass

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="ltamp-parent-watch", daemon=True).start()


def _worker(job: CollectJob, tasks: Any, results: Any, parent: int) -> None:
    die_with_parent(parent)
    # Ctrl-C goes to the whole process group: the parent decides what happens.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    runner = TrialRunner(job)
    try:
        while (index := tasks.get()) is not None:
            try:
                results.put(("ok", runner.run(index).to_json()))
            except Exception as error:  # report, don't hang the parent
                results.put(("error", f"trial {index}: {type(error).__name__}: {error}"))
    finally:
        runner.close()


def _serial(job: CollectJob, indices: list[int]) -> Iterator[TrialRecord]:
    runner = TrialRunner(job)
    try:
        for index in indices:
            yield runner.run(index)
    finally:
        runner.close()


def _parallel(job: CollectJob, indices: list[int], workers: int) -> Iterator[TrialRecord]:
    # Fork (where there is one): spawned children would re-run an unguarded ``__main__``
    # such as ``python -m ltamp_cli``; nothing here holds threads or locks when forking.
    methods = mp.get_all_start_methods()
    context = mp.get_context("fork" if "fork" in methods else "spawn")
    tasks, results = context.Queue(), context.Queue()
    for index in indices:
        tasks.put(index)
    for _ in range(workers):
        tasks.put(None)
    processes = [
        context.Process(target=_worker, args=(job, tasks, results, os.getpid()), daemon=True)
        for _ in range(workers)
    ]
    for process in processes:
        process.start()
    try:
        for _ in indices:
            while True:
                try:
                    kind, payload = results.get(timeout=1.0)
                    break
                except queue.Empty:
                    if not any(p.is_alive() for p in processes):
                        raise RuntimeError("all collection workers died") from None
            if kind == "error":
                raise RuntimeError(payload)
            yield TrialRecord.from_dict(json.loads(payload))
    finally:
        for process in processes:
            if process.is_alive():
                process.terminate()
        for process in processes:
            process.join(timeout=5)
        # Indices not yet taken may still sit in the feeder thread, blocked writing to a
        # full pipe that no worker reads any more: without this, the interpreter waits for
        # that thread at exit and an interrupted ``collect`` never ends. They are not data
        # (a resume queues them again).
        for channel in (tasks, results):
            channel.cancel_join_thread()
            channel.close()


def collect(
    job: CollectJob,
    out: str | Path,
    *,
    workers: int | None = 1,
    progress: bool = True,
    ray_address: str | None = None,
    wait: bool = False,
) -> int:
    """Run the trials of ``job`` missing from ``out``; returns how many were added.

    ``workers`` local processes (``None``: 1), or with ``ray_address`` that many Ray actors
    (``"local"`` starts a local Ray cluster; ``None`` workers: every CPU of the cluster).
    Records are appended as they finish (possibly out of index order). Interrupting
    (Ctrl-C, kill) keeps every trial already appended; run again to resume. One collection
    writes ``out`` at a time: another one holding it is an :class:`InputError` (or, with
    ``wait``, waited for).
    """
    # The limits and words of `ltamp collect`, which calls this function for its checks.
    if job.n < 0:
        raise InputError(f"-n: expected a number >= 0, got {job.n}")
    if workers is not None and workers < 1:
        raise InputError(f"--workers: expected a number >= 1, got {workers}")
    if Path(out).is_dir():
        raise InputError(f"--out: {out} is a directory, expected a .jsonl file path")
    check_robot(job.robot, job.backend, job.skill)
    if ray_address is not None and not ray_address.strip():
        raise InputError("--ray: expected 'local' or a Ray cluster address, got ''")
    job = replace(job, seed=usable_seed(job.seed))
    dataset = TrialDataset(out)
    job = with_setup(job)  # also checks the skill; fills the setup and physics
    with ExitStack() as session:
        session.enter_context(exclusive_writer(out, is_directory=False, wait=wait))
        indices = pending_indices(dataset, job)
        stream: Iterator[TrialRecord]
        if ray_address is not None:
            from ltamp_cli.trials.ray_collect import import_ray, ray_session, ray_stream

            import_ray()  # a missing Ray is reported even when nothing is left to run
            # Ray starts (or is joined) before the progress bar, and only if there is work.
            ray = session.enter_context(ray_session(ray_address, workers)) if indices else None
            stream = ray_stream(ray, job, indices, workers) if ray is not None else iter(())
        elif (workers or 1) == 1 or len(indices) <= 1:
            stream = _serial(job, indices)
        else:
            stream = _parallel(job, indices, min(workers or 1, len(indices)))
        return _append_all(dataset, job, stream, len(indices), progress)


def _append_all(
    dataset: TrialDataset,
    job: CollectJob,
    stream: Iterator[TrialRecord],
    pending: int,
    progress: bool,
) -> int:
    """Append records from ``stream`` one by one as they arrive; returns how many."""
    added = 0
    with tqdm(
        total=job.n,
        initial=job.n - pending,
        desc=f"{job.tag}/{job.skill}",
        unit="trial",
        disable=not progress,
        dynamic_ncols=True,
    ) as bar:
        for record in stream:
            dataset.append(record)
            added += 1
            bar.update(1)
    return added
