"""Round 4: each entry point's Python API has the CLI's limits and says the same words.

Table-driven: every row is one bad value given to ``ltamp <command>`` and to the Python API
that command calls. The CLI must exit 2 with exactly one stderr line,
``ltamp: error: <message>``; the API must raise with that same ``<message>`` (the CLI's
option name included, as the CLI's other API-backed checks do).

Bugs this file caught (failed before the fix, one commit): ``collect(job, out)`` of the
Python API
* on a directory ``out`` raised a bare ``IsADirectoryError`` traceback (the CLI: "--out: …
  is a directory");
* with ``CollectJob(robot="r2d2")`` answered "unknown synthetic backend option(s): robot",
  and ``robot="panda"`` on a Box2D skill reached the backend (the CLI: "--robot: expected
  one of none, panda" / "only --backend pybullet …"): the robot check lived in the CLI only;
* refused ``n=-1`` / ``workers=0`` in other words than ``ltamp collect`` did.

and ``SkillEvaluator.synthetic`` (what ``ltamp evaluate`` calls on a synthetic backend)
failed in numpy for ``n_test=0`` ("cannot reshape array of size 0") and accepted
``n_contexts=-1`` (separate commit).
"""

from __future__ import annotations

import io
import math
from collections.abc import Callable
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

import pytest

from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError

ApiCall = Callable[[Path], Any]


def _cli(argv: list[str]) -> tuple[int, list[str]]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(argv)
    return int(done.value.code or 0), [line for line in err.getvalue().splitlines() if line]


def _collect(n: int = 2, workers: int | None = 1, robot: str = "none", skill: str = "toy1d",
             backend: str = "synthetic", out: str = "c.jsonl") -> tuple[list[str], ApiCall]:
    def api(tmp: Path) -> Any:
        from ltamp_cli.trials.collect import CollectJob, collect

        job = CollectJob(skill=skill, backend=backend, n=n, robot=robot)
        return collect(job, tmp / out, workers=workers, progress=False)

    argv = ["collect", skill, "-n", str(n), "--out", "{tmp}/" + out, "--backend", backend,
            "--robot", robot, *(["--workers", str(workers)] if workers is not None else [])]
    return argv, api


def _train(skill: str = "toy1d", **config: Any) -> tuple[list[str], ApiCall]:
    def api(tmp: Path) -> Any:
        from ltamp_cli.backends import load_backend
        from ltamp_cli.learning.active import LearningConfig, learn_online
        from ltamp_cli.trials.record import TrialDataset

        physics = load_backend("synthetic")
        try:
            return learn_online(physics, skill, LearningConfig(**config),
                                TrialDataset(tmp / "trials.jsonl"))
        finally:
            physics.close()

    argv = ["train", skill, "--out", "{tmp}/model", "--backend", "synthetic"]
    for key, value in config.items():
        argv += [f"--{key}", str(value)]
    return argv, api


def _solve(**config: Any) -> tuple[list[str], ApiCall]:
    def api(tmp: Path) -> Any:
        from ltamp_cli.planner.algorithms.common import PlannerConfig
        from ltamp_cli.planner.api import solve
        from ltamp_cli.planner.problem import load_problem

        return solve(load_problem("examples/tamp2d_blocked"), PlannerConfig(**config))

    argv = ["solve", "examples/tamp2d_blocked", "--no-stats"]
    for key, value in config.items():
        argv += [f"--{key.replace('_', '-')}", str(value)]
    return argv, api


def _evaluate(trials: int = 50, n_test: int = 2000) -> tuple[list[str], ApiCall]:
    def api(tmp: Path) -> Any:
        from ltamp_cli.backends import load_backend
        from ltamp_cli.learning.metrics import SkillEvaluator

        physics = load_backend("synthetic")
        try:
            return SkillEvaluator.synthetic(physics, "toy1d", n_test, trials)
        finally:
            physics.close()

    return ["evaluate", "{tmp}/model", "--trials", str(trials), "--n-test", str(n_test)], api


ROWS = {
    "collect -n -1": _collect(n=-1),
    "collect --workers 0": _collect(workers=0),
    "collect --out a directory": _collect(out="folder"),
    "collect --robot r2d2": _collect(robot="r2d2"),
    "collect --robot panda on synthetic": _collect(robot="panda"),
    "collect unknown skill": _collect(skill="nope"),
    "collect unknown backend": _collect(backend="nope"),
    "train --budget 0": _train(budget=0),
    "train --init -1": _train(init=-1),
    "train --strategy x": _train(strategy="x"),
    "train --kernel x": _train(kernel="x"),
    "evaluate --n-test 0": _evaluate(n_test=0),
    "evaluate --trials -1": _evaluate(trials=-1),
    "solve --algorithm x": _solve(algorithm="x"),
    "solve --search x": _solve(search="x"),
    "solve --success-cost nan": _solve(success_cost=math.nan),
}


@pytest.mark.parametrize("name", list(ROWS))
def test_api_and_cli_refuse_a_bad_value_with_the_same_line(name: str, tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch
                                                            ) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    (tmp_path / "folder").mkdir()
    argv, api = ROWS[name]
    code, lines = _cli([arg.replace("{tmp}", str(tmp_path)) for arg in argv])
    assert code == 2, (code, lines)
    assert len(lines) == 1 and lines[0].startswith("ltamp: error: "), lines
    with pytest.raises((InputError, ValueError, KeyError)) as caught:
        api(tmp_path)
    message = caught.value.args[0] if isinstance(caught.value, KeyError) else str(caught.value)
    assert lines[0] == f"ltamp: error: {message}"
    # Nothing was written by either refusal.
    assert not (tmp_path / "c.jsonl").exists()
    assert not (tmp_path / "model" / "trials.jsonl").exists()
