"""A fixed corpus of hostile inputs, run as real ``ltamp`` subprocesses with a time limit.

Each :class:`HostileCase` builds its files in a fresh folder (next to a sandbox copy of
``domains/``), names the command to run and what must hold afterwards. The oracle
(:func:`run_case`) fails a case on a traceback, a time-out, an exit code other than 0/1 or
2-with-one-line, a file written outside the case's folder and cache, or a payload that ran
(model directories and caches are data: their payloads write a marker file if executed).
Shared by ``tests/fuzz/test_hostile_inputs.py`` and ``bench/fuzz.py``.
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from ltamp_fuzz import REPO, Outcome, acceptable, run_cli

TAMP2D_PROBLEM = (REPO / "problems" / "examples" / "tamp2d_blocked.yaml").read_text()
MARKER = "PAYLOAD_RAN"


@dataclass(frozen=True)
class HostileCase:
    """``setup(case_dir, domains_dir) -> argv``; ``expect_code`` pins the exit code."""

    name: str
    setup: Callable[[Path, Path], list[str]]
    expect_code: int | None = 2
    expect_in_stderr: str = ""
    env: dict[str, str] = field(default_factory=dict)
    # Commands that import torch take seconds to start: those run in-process (same CLI code).
    in_process: bool = False


def _problem(case: Path, domains: Path, *, domain: str | None = None,
             bindings: str | None = None, extra: str = "", goal: str | None = None) -> Path:
    text = TAMP2D_PROBLEM.replace("../../domains/tamp2d/streams.py",
                                  bindings or str(domains / "tamp2d" / "streams.py"))
    text = text.replace("../../domains/tamp2d", domain or str(domains / "tamp2d"))
    if goal is not None:
        text = text.replace("goal: (In a goal)", f"goal: {goal}")
    path = case / "problem.yaml"
    path.write_text(text + extra)
    return path


def _copy_domain(domains: Path, name: str, target: Path) -> Path:
    target.mkdir(parents=True, exist_ok=True)
    for file in (domains / name).iterdir():
        if file.is_file():
            (target / file.name).write_bytes(file.read_bytes())
    return target


def _bindings_variant(case: Path, domains: Path, old: str, new: str) -> Path:
    source = (domains / "tamp2d" / "streams.py").read_text()
    assert old in source
    path = case / "bindings.py"
    path.write_text(source.replace(old, new))
    return path


class _Payload:
    """Unpickling it writes the marker: proof that data ran as code."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):  # type: ignore[no-untyped-def]
        return (Path.write_text, (self.marker, "ran"))


def _model_dir(case: Path, mutate: Callable[[Path, dict], None]) -> Path:
    """A valid random-baseline model directory, then ``mutate(dir, metadata)``."""
    directory = case / "model"
    directory.mkdir()
    model = json.loads((REPO / "models" / "kitchen2d" / "pour" / "model.json").read_text())
    mutate(directory, model)
    (directory / "model.json").write_text(json.dumps(model))
    return directory


def _with_digest(directory: Path, metadata: dict, name: str = "weights.npz") -> None:
    metadata["weights_sha256"] = hashlib.sha256((directory / name).read_bytes()).hexdigest()


def _pickled_npz(directory: Path, metadata: dict) -> None:
    (directory / "weights.npz").write_bytes(pickle.dumps(_Payload(directory.parent / MARKER)))
    metadata["kind"] = "rf-c"
    _with_digest(directory, metadata)


def _pickled_pkl(directory: Path, metadata: dict) -> None:
    (directory / "weights.pkl").write_bytes(pickle.dumps(_Payload(directory.parent / MARKER)))
    metadata["kind"] = "nn-r"
    _with_digest(directory, metadata, "weights.pkl")


def _nan_gp(directory: Path, metadata: dict) -> None:
    import numpy as np

    with np.load(REPO / "models" / "kitchen2d" / "pour" / "weights.npz") as weights:
        arrays = {name: weights[name].copy() for name in weights.files}
    arrays["y"][0] = np.nan
    np.savez(directory / "weights.npz", **arrays)
    _with_digest(directory, metadata)


def _object_array(directory: Path, metadata: dict) -> None:
    import numpy as np

    np.savez(directory / "weights.npz",
             x=np.array([_Payload(directory.parent / MARKER)], dtype=object))
    _with_digest(directory, metadata)


def _deep_json(directory: Path, metadata: dict) -> None:
    metadata["extra"] = json.loads("[" * 900 + "]" * 900)


def _cases() -> list[HostileCase]:
    cases: list[HostileCase] = []

    def add(name: str, expect_code: int | None = 2, contains: str = "",
            env: dict[str, str] | None = None, in_process: bool = False) -> Callable:
        def register(setup: Callable[[Path, Path], list[str]]) -> Callable:
            cases.append(HostileCase(name, setup, expect_code, contains, env or {}, in_process))
            return setup
        return register

    @add("yaml nested 1000 deep", contains="nested deeper")
    def _(case: Path, domains: Path) -> list[str]:
        return ["check", str(_problem(case, domains, extra="x: " + "[" * 1000 + "]" * 1000))]

    @add("yaml duplicate key", contains="duplicate key")
    def _(case: Path, domains: Path) -> list[str]:
        return ["check", str(_problem(case, domains, extra="goal: (In b goal)\n"))]

    @add("pddl goal nested 5000 deep", contains="nested deeper")
    def _(case: Path, domains: Path) -> list[str]:
        goal = "(and " * 5000 + "(In a goal)" + ")" * 5000
        return ["solve", str(_problem(case, domains, goal=goal)), "--max-time", "2"]

    @add("pddl domain nested 5000 deep", contains="nested deeper")
    def _(case: Path, domains: Path) -> list[str]:
        folder = _copy_domain(domains, "blocksworld", case / "bw")
        text = (folder / "domain.pddl").read_text()
        deep = "(and " * 5000 + "(clear ?x)" + ")" * 5000
        (folder / "domain.pddl").write_text(text.replace("(clear ?x)", deep, 1))
        return ["check", str(folder / "blocks8.pddl"), "--domain", str(folder)]

    @add("255+ byte domain path component", contains="too long")
    def _(case: Path, domains: Path) -> list[str]:
        return ["check", str(_problem(case, domains, domain="d" * 300))]

    @add("255+ byte bindings path component", contains="too long")
    def _(case: Path, domains: Path) -> list[str]:
        return ["solve", str(_problem(case, domains, bindings="b" * 300 + ".py"))]

    @add("bindings raise SystemExit at import", contains="SystemExit")
    def _(case: Path, domains: Path) -> list[str]:
        (case / "exit.py").write_text("raise SystemExit(7)\n")
        return ["check", str(_problem(case, domains, bindings=str(case / "exit.py")))]

    @add("make_streams raises a BaseException", contains="Boom")
    def _(case: Path, domains: Path) -> list[str]:
        (case / "boom.py").write_text("class Boom(BaseException):\n    pass\n\n\n"
                                      "def make_streams(world, rng):\n    raise Boom('x')\n")
        return ["solve", str(_problem(case, domains, bindings=str(case / "boom.py")))]

    @add("a test stream written as a generator", contains="generator")
    def _(case: Path, domains: Path) -> list[str]:
        bindings = _bindings_variant(
            case, domains, "        note(block1, pose1)\n",
            "        yield False\n        note(block1, pose1)\n")
        return ["check", str(_problem(case, domains, bindings=str(bindings)))]

    for label, value in (("NaN", 'float("nan")'), ("negative", "-3.0")):
        @add(f"{label} action cost", contains="cost")
        def _(case: Path, domains: Path, value: str = value) -> list[str]:
            bindings = _bindings_variant(
                case, domains, "        return round((transit_height",
                f"        return {value}\n        return round((transit_height")
            problem = _problem(case, domains, bindings=str(bindings))
            return ["solve", str(problem), "--max-time", "5"]

    @add("stream input missing from its :domain", contains="occurs in no fact")
    def _(case: Path, domains: Path) -> list[str]:
        folder = _copy_domain(domains, "tamp2d", case / "t2")
        text = (folder / "stream.pddl").read_text()
        (folder / "stream.pddl").write_text(text.replace(":inputs (?b ?p ?g)",
                                                         ":inputs (?b ?p ?g ?z)"))
        return ["solve", str(_problem(case, domains, domain=str(folder)))]

    @add("cyclic negated derived predicates", contains="stratified")
    def _(case: Path, domains: Path) -> list[str]:
        folder = _copy_domain(domains, "blocksworld", case / "bw")
        text = (folder / "domain.pddl").read_text()
        text = text.replace(":action-costs)", ":action-costs :derived-predicates)")
        text = text.replace("(:predicates", "(:predicates (p ?x - block) (q ?x - block)", 1)
        text = text.replace("(:action", "(:derived (p ?x - block) (not (q ?x)))\n"
                            "  (:derived (q ?x - block) (p ?x))\n  (:action", 1)
        (folder / "domain.pddl").write_text(text)
        return ["check", str(folder / "blocks8.pddl"), "--domain", str(folder)]

    @add("domain named like a path escaping the cache", expect_code=0)
    def _(case: Path, domains: Path) -> list[str]:
        folder = _copy_domain(domains, "blocksworld", case / "bw")
        for name in ("domain.pddl", "blocks8.pddl"):
            text = (folder / name).read_text().replace("blocksworld", "../../../../escaped")
            (folder / name).write_text(text)
        return ["solve", str(folder / "blocks8.pddl"), "--domain", str(folder)]

    @add("corrupt statistics cache", expect_code=0, contains="corrupt")
    def _(case: Path, domains: Path) -> list[str]:
        from ltamp_cli.planner.statistics import statistics_file_name

        stats = case / "cache" / "ltamp" / "stream-statistics"
        stats.mkdir(parents=True)
        (stats / statistics_file_name("tamp2d")).write_text('{"streams": {"x": [' * 50)
        return ["solve", str(_problem(case, domains)), "--max-time", "20"]

    @add("unwritable cache (a file)", expect_code=0, contains="not saved",
         env={"XDG_CACHE_HOME": "{case}/cache-file"})
    def _(case: Path, domains: Path) -> list[str]:
        (case / "cache-file").write_text("")
        return ["solve", str(_problem(case, domains)), "--max-time", "20"]

    @add("negative seed", expect_code=0)
    def _(case: Path, domains: Path) -> list[str]:
        return ["solve", str(_problem(case, domains)), "--seed", "-1", "--max-time", "20"]

    @add("collect --out under a file", contains="--out", in_process=True)
    def _(case: Path, domains: Path) -> list[str]:
        (case / "file").write_text("")
        return ["collect", "moving2d", "--backend", "synthetic", "-n", "2",
                "--out", str(case / "file" / "t.jsonl")]

    @add("collect --seed -1", expect_code=0, in_process=True)
    def _(case: Path, domains: Path) -> list[str]:
        return ["collect", "moving2d", "--backend", "synthetic", "-n", "3", "--seed", "-1",
                "--out", str(case / "t.jsonl")]

    @add("sample --plot under a file", contains="--plot", in_process=True)
    def _(case: Path, domains: Path) -> list[str]:
        (case / "file").write_text("")
        return ["sample", str(REPO / "models" / "kitchen2d" / "pour"),
                "--plot", str(case / "file" / "x.png")]

    @add("sample --kernel-file missing", contains="--kernel-file", in_process=True)
    def _(case: Path, domains: Path) -> list[str]:
        return ["sample", str(REPO / "models" / "kitchen2d" / "pour"), "--sampler",
                "diverse-lk", "--kernel-file", str(case / "missing.json")]

    @add("plot level-set --out name over 255 bytes", contains="255", in_process=True)
    def _(case: Path, domains: Path) -> list[str]:
        return ["plot", "level-set", str(REPO / "models" / "kitchen2d" / "pour"),
                "--out", str(case / ("p" * 300 + ".png"))]

    for label, mutate in (("pickled weights.npz", _pickled_npz),
                          ("pickled weights.pkl", _pickled_pkl),
                          ("NaN in GP weights", _nan_gp),
                          ("object array in weights.npz", _object_array),
                          ("model.json nested 900 deep", _deep_json)):
        @add(f"hostile model dir: {label}", in_process=True)
        def _(case: Path, domains: Path, mutate: Callable = mutate) -> list[str]:
            return ["evaluate", str(_model_dir(case, mutate))]

    return cases


CORPUS = _cases()
FAST_COMMANDS = ("check", "solve")


def run_case(case: HostileCase, workdir: Path, domains: Path, timeout: float = 120.0
             ) -> tuple[Outcome, str | None]:
    """Set up and run ``case`` in ``workdir`` (fresh, empty); ``(outcome, why it failed)``."""
    argv = case.setup(workdir, domains)
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1",
           "XDG_CACHE_HOME": str(workdir / "cache"), "HOME": str(workdir / "home")}
    env.update({key: value.format(case=workdir) for key, value in case.env.items()})
    if case.in_process:
        before = _snapshot(domains.parent, workdir)
        outcome = run_cli(argv)
        why = acceptable(outcome) or _changes(before, _snapshot(domains.parent, workdir))
    else:
        outcome, why = run_subprocess(argv, workdir, env, timeout, watch=domains.parent)
    if why is None and (workdir / MARKER).exists():
        why = "a payload in data ran as code"
    if why is None and case.expect_code is not None and outcome.code != case.expect_code:
        why = f"exit {outcome.code}, expected {case.expect_code}"
    if why is None and case.expect_in_stderr and case.expect_in_stderr not in outcome.stderr:
        why = f"stderr lacks {case.expect_in_stderr!r}"
    return outcome, why


def _snapshot(root: Path, skip: Path) -> dict[str, int]:
    """Every file under ``root`` (except under ``skip``) with its modification time."""
    files: dict[str, int] = {}
    for folder, _dirs, names in os.walk(root):
        if Path(folder).is_relative_to(skip):
            continue
        for name in names:
            path = Path(folder) / name
            try:
                files[str(path)] = path.stat().st_mtime_ns
            except OSError:
                continue
    return files


def run_subprocess(argv: list[str], cwd: Path, env: dict[str, str], timeout: float,
                   watch: Path | None = None) -> tuple[Outcome, str | None]:
    """Run ``ltamp ARGV`` in ``cwd``; a time-out, a bad outcome or (with ``watch``) a file
    changed under ``watch`` outside ``cwd`` is the returned reason."""
    before = _snapshot(watch, cwd) if watch is not None else {}
    try:
        done = subprocess.run([sys.executable, "-m", "ltamp_cli", *argv], cwd=cwd, env=env,
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return Outcome(-1, "", ""), f"no answer within {timeout:.0f} s"
    outcome = Outcome(done.returncode, done.stdout, done.stderr)
    why = acceptable(outcome)
    if why is None and watch is not None:
        why = _changes(before, _snapshot(watch, cwd))
    return outcome, why


def _changes(before: dict[str, int], after: dict[str, int]) -> str | None:
    changed = sorted(path for path, stamp in after.items() if before.get(path) != stamp)
    return f"wrote outside its folder: {changed[:3]}" if changed else None


def solve_mutation(root: Path, target_file: str, problem: str, text: str,
                   timeout: float = 120.0) -> tuple[Outcome, str | None]:
    """Write ``text`` over ``root/target_file``, ``ltamp solve`` ``root/problem`` in a
    subprocess (own cache, 3 s planning limit, ``timeout`` in all), restore the file."""
    import tempfile

    path = root / target_file
    original = path.read_text()
    path.write_text(text)
    try:
        with tempfile.TemporaryDirectory(dir=root) as workdir:
            env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1",
                   "XDG_CACHE_HOME": str(Path(workdir) / "cache")}
            return run_subprocess(["solve", str(root / problem), "--max-time", "3"],
                                  Path(workdir), env, timeout, watch=root)
    finally:
        path.write_text(original)
