"""The Python API refuses a context outside the trained range as ``ltamp sample`` does.

Before the fix ``make_sampler`` sampled a context the model never saw (the CLI refused it):
the GP's mean reverts to its prior there, so the "learned" set is a guess. Now one check
(:func:`ltamp_cli.sampling.factory.outside_trained_range`) serves ``ltamp sample``,
``ltamp plot level-set``, ``make_sampler`` (``extrapolate=True`` opts in) and learned
streams (``extrapolate: true`` in ``world.learned_streams.<stream>`` opts in; otherwise such
a call yields nothing and one warning names the stream's skill and the context).
"""

from __future__ import annotations

import io
import logging
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.cli.app import main
from ltamp_cli.learned_streams.stream import LearnedStream, LearnedStreamConfig
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.sampling.factory import make_sampler

REPO = Path(__file__).resolve().parents[2]
MODEL = REPO / "domains" / "synthetic_goodregion" / "model"  # moving2d, phase in [0, 1]
PROBLEM = REPO / "problems" / "examples" / "synthetic_goodregion.yaml"


def _cli(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(list(argv))
    return int(done.value.code or 0), out.getvalue(), err.getvalue()


def test_api_and_cli_refuse_the_same_context_with_the_same_words() -> None:
    model = load_model(MODEL).model
    with pytest.raises(ValueError, match=r"outside the trained range") as refused:
        make_sampler("adaptive", model, np.array([1.5]), np.random.default_rng(0))
    code, _out, err = _cli("sample", str(MODEL), "--context", "phase=1.5", "-n", "2")
    assert code == 2 and len(err.strip().splitlines()) == 1
    detail = "phase=1.5 not in [0, 1]"
    assert detail in err and detail in str(refused.value)


def test_api_extrapolates_only_when_asked() -> None:
    model = load_model(MODEL).model
    sampler = make_sampler("adaptive", model, np.array([1.5]), np.random.default_rng(0),
                           extrapolate=True)
    controls = np.array([next(sampler) for _ in range(3)])
    assert controls.shape == (3, 2) and np.all(np.isfinite(controls))
    # both ends of the box are inside (inclusive bounds)
    for phase in (0.0, 1.0):
        make_sampler("rejection", model, np.array([phase]), np.random.default_rng(0))


def _stream(extrapolate: bool) -> LearnedStream:
    return LearnedStream(LearnedStreamConfig(MODEL, "adaptive", extrapolate=extrapolate),
                         lambda phase: np.array([phase]),
                         lambda control, phase: (tuple(control.tolist()),),
                         np.random.default_rng(0))


def test_learned_stream_yields_nothing_outside_unless_it_may_extrapolate(
        caplog: pytest.LogCaptureFixture) -> None:
    stream = _stream(extrapolate=False)
    with caplog.at_level(logging.WARNING, logger="ltamp"):
        assert list(stream(1.5)) == [] and list(stream(-0.2)) == []
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "outside the trained range" in warnings[0]
    assert "extrapolate: true" in warnings[0] and stream.n_outside == 2
    inside = stream(0.2)
    assert len(next(inside)[0]) == 2  # inside the range it samples as before
    extrapolating = _stream(extrapolate=True)(1.5)
    assert len(next(extrapolating)[0]) == 2


@pytest.mark.parametrize("setting, expected", [
    ("extrapolate: 'yes'", "expected true or false"),
    ("extrapolate: 1", "expected true or false"),
])
def test_bad_extrapolate_setting_is_one_line(tmp_path: Path, setting: str,
                                             expected: str) -> None:
    text = PROBLEM.read_text().replace("../../domains", str(REPO / "domains"))
    text = text.replace("      sampler: diverse-lk\n",
                        f"      sampler: diverse-lk\n      {setting}\n")
    assert setting in text
    path = tmp_path / "problem.yaml"
    path.write_text(text)
    code, _out, err = _cli("check", str(path))
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, lines
    assert "world.learned_streams.sample-good-control.extrapolate" in lines[0], lines
    assert expected in lines[0] and "problem.yaml:12:" in lines[0]  # file:line:column


@pytest.mark.parametrize("kwargs, expected", [
    ({"beta": float("nan")}, "beta: expected a finite number"),
    ({"beta": float("inf")}, "beta: expected a finite number"),
    ({"lam": 0.5}, "lambda: expected a value in [0.95, 0.999]"),
    ({"lam": 0.5, "beta": 1.0}, "lambda: expected a value in [0.95, 0.999]"),
    ({"n_proposals": 0}, "n_proposals and buffer_size must be >= 1"),
])
def test_api_sampler_options_have_the_cli_limits(kwargs: dict, expected: str) -> None:
    """Before: beta=nan gave a sampler whose next() raised a bare StopIteration, beta=inf an
    empty one, lam=0.5 with a beta passed, and n_proposals=0 a numpy concatenate error; the
    CLI's --beta/--lambda refuse them (`ltamp sample`: one line)."""
    model = load_model(MODEL).model
    with pytest.raises(ValueError) as refused:
        make_sampler("adaptive", model, np.array([0.3]), np.random.default_rng(0), **kwargs)
    assert expected in str(refused.value)
    if "n_proposals" not in kwargs:
        option = ["--beta", str(kwargs["beta"])] if "lam" not in kwargs else \
            ["--lambda", str(kwargs["lam"])]
        code, _out, err = _cli("sample", str(MODEL), "--context", "phase=0.3", *option)
        assert code == 2 and expected in err


def test_api_training_takes_any_integer_seed_and_names_unknown_skills() -> None:
    """Before: LearningConfig(seed=-1) failed in numpy ("expected non-negative integer")
    while `ltamp train --seed -1` runs; an unknown skill was a bare KeyError('nope')."""
    from ltamp_cli.backends import load_backend
    from ltamp_cli.learning.active import LearningConfig, learn_online
    from ltamp_cli.seeds import usable_seed

    backend = load_backend("synthetic")
    try:
        assert LearningConfig(seed=-1).seed == usable_seed(-1) >= 0
        result = learn_online(backend, "moving2d", LearningConfig(budget=4, init=2, seed=-1))
        assert len(result.records) == 4
        with pytest.raises(KeyError, match="has no skill 'nope' \\(known: "):
            learn_online(backend, "nope", LearningConfig(budget=4, init=2))
    finally:
        backend.close()


def test_a_value_just_outside_is_printed_with_every_digit() -> None:
    """Before: a=0.5000000001 against [0.5, 0.5] read "a=0.5 not in [0.5, 0.5]"."""
    from ltamp_cli.backends.protocol import ParamSpace, SkillSpec
    from ltamp_cli.sampling.factory import outside_trained_range

    spec = SkillSpec("s", ParamSpace(("a", "b"), (0.5, 0.0), (0.5, 1.0)),
                     ParamSpace(("u",), (0.0,), (1.0,)))
    assert outside_trained_range(spec, np.array([0.5, 1.0])) == ""
    assert outside_trained_range(spec, np.array([0.5000000001, 1.5])) == (
        "a=0.5000000001 not in [0.5, 0.5]; b=1.5 not in [0, 1]")
